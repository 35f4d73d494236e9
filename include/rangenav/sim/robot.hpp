#pragma once
// A simulated differential-drive robot: it follows (v, omega) commands at a fixed control rate
// (exact arc integration of the unicycle model), knows its true pose, integrates an odometry
// pose from wheel velocities with configurable systematic (scale, bias) and random errors, and
// checks its footprint (circle or rectangle, over a height band) against the World, reporting the
// primitives it touches. A step that would end in contact is not carried out (the robot stops,
// as on a bumper hit) and its contacts are returned.

#include <algorithm>
#include <boost/geometry.hpp>
#include <boost/geometry/geometries/point_xy.hpp>
#include <boost/geometry/geometries/polygon.hpp>
#include <boost/geometry/geometries/segment.hpp>
#include <cmath>
#include <cstddef>
#include <random>
#include <string_view>
#include <vector>

#include "rangenav/core/angles.hpp"
#include "rangenav/core/error.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/sim/world.hpp"

namespace rangenav::sim {

/// The robot's outline on the floor and the height band it occupies: obstacles whose z-range
/// overlaps [z_min, z_max] can be touched; a table top above z_max can be driven under.
struct Footprint {
  /// The footprint's form.
  enum class Shape { circle, rectangle };
  Shape shape{Shape::circle};  ///< circle or rectangle
  double radius{0.3};          ///< circle
  double length{0.6};          ///< rectangle, along the robot's x axis
  double width{0.5};           ///< rectangle, along y
  double x_offset{0.0};        ///< rectangle centre ahead of the rotation centre
  double z_min{0.02};          ///< ground clearance (m)
  double z_max{1.2};           ///< top of the robot (m)

  /// A circular footprint of `radius` (m) over the height band [z_min, z_max].
  [[nodiscard]] static Footprint circle(double radius, double z_min = 0.02, double z_max = 1.2) {
    Footprint f;
    f.radius = radius;
    f.z_min = z_min;
    f.z_max = z_max;
    return f;
  }
  /// A rectangular footprint `length` x `width` (m) over [z_min, z_max], its centre `x_offset`
  /// ahead of the rotation centre.
  [[nodiscard]] static Footprint rectangle(double length, double width, double z_min = 0.02,
                                           double z_max = 1.2, double x_offset = 0.0) {
    Footprint f;
    f.shape = Shape::rectangle;
    f.length = length;
    f.width = width;
    f.x_offset = x_offset;
    f.z_min = z_min;
    f.z_max = z_max;
    return f;
  }

  /// Throws invalid_argument for a non-positive size or an empty height band.
  void validate(std::string_view where) const {
    if (shape == Shape::circle) {
      detail::require_positive(where, "footprint.radius", radius);
    } else {
      detail::require_positive(where, "footprint.length", length);
      detail::require_positive(where, "footprint.width", width);
      detail::require_finite(where, "footprint.x_offset", x_offset);
    }
    detail::require_finite(where, "footprint.z_min", z_min);
    detail::require_finite(where, "footprint.z_max", z_max);
    if (!(z_max > z_min))
      detail::throw_invalid_argument(
          where, "footprint.z_max", z_max,
          "must exceed footprint.z_min = " + detail::format_value(z_min));
  }

  /// Radius of the circle that contains the footprint (about the rotation centre).
  [[nodiscard]] double bounding_radius() const {
    return shape == Shape::circle ? radius : std::hypot(std::abs(x_offset) + length / 2, width / 2);
  }
};

namespace footprint_geometry {
using FootprintPoint = boost::geometry::model::d2::point_xy<double>;
using FootprintPolygon =
    boost::geometry::model::polygon<FootprintPoint, false, true>;  // CCW, closed

inline FootprintPoint footprint_point(const Point2d& v) {
  return {v.x(), v.y()};
}

/// The rectangle with centre c, half extents `half` and yaw, as a closed polygon.
inline FootprintPolygon footprint_rect(const Point2d& c, const Point2d& half, double yaw) {
  const Eigen::Rotation2Dd r(yaw);
  FootprintPolygon poly;
  for (const auto& [sx, sy] :
       {std::pair{-1.0, -1.0}, {1.0, -1.0}, {1.0, 1.0}, {-1.0, 1.0}, {-1.0, -1.0}})
    poly.outer().push_back(footprint_point(c + r * Point2d(sx * half.x(), sy * half.y())));
  return poly;
}

/// A rectangular footprint's body at a pose.
inline FootprintPolygon footprint_body(const Footprint& fp, const Pose2d& pose) {
  return footprint_rect(pose.transform_point({fp.x_offset, 0}), {fp.length / 2, fp.width / 2},
                        pose.theta);
}

/// A footprint at a pose as Boost.Geometry sees it: a disc (centre, radius) or a body polygon.
class PlacedFootprint {
 public:
  /// Places `fp` at `pose`.
  PlacedFootprint(const Footprint& fp, const Pose2d& pose)
      : circle_(fp.shape == Footprint::Shape::circle),
        radius_(fp.radius),
        centre_(pose.x, pose.y),
        body_(circle_ ? FootprintPolygon{} : footprint_body(fp, pose)) {}

  /// Distance (m) to a geometry grown by `grow` (a cylinder: its axis point grown by its
  /// radius); 0 or less when they touch. A disc's is its centre's minus its radius.
  template <class Geometry>
  [[nodiscard]] double distance(const Geometry& g, double grow = 0) const {
    namespace bg = boost::geometry;
    return (circle_ ? bg::distance(centre_, g) - radius_ : bg::distance(body_, g)) - grow;
  }
  /// Whether it touches the geometry grown by `grow`: distance(g, grow) <= 0, answered for an
  /// ungrown geometry and a body by Boost's intersects (half the cost of its distance).
  template <class Geometry>
  [[nodiscard]] bool touches(const Geometry& g, double grow = 0) const {
    if (circle_ || grow > 0) return distance(g, grow) <= 0;
    return boost::geometry::intersects(body_, g);
  }

 private:
  bool circle_;
  double radius_;
  FootprintPoint centre_;
  FootprintPolygon body_;
};

/// Calls visit(ref, geometry, grow) for every primitive within `reach` of the footprint's
/// bounding circle whose height band meets the footprint's (floor holes at any height):
/// `geometry` is its outline on the floor (a wall's segment, a box's, door leaf's or hole's
/// rectangle, a cylinder's axis point), `grow` how far the primitive reaches beyond it (a
/// cylinder's radius, else 0). PlacedFootprint measures the footprint against it.
template <class Visit>
void for_each_primitive_near(const World& world, const Footprint& fp, const Pose2d& pose,
                             double reach, Visit&& visit) {
  using Segment = boost::geometry::model::segment<FootprintPoint>;
  const auto band = [&](double z0, double z1) { return z0 <= fp.z_max && z1 >= fp.z_min; };
  const double r = fp.bounding_radius() + reach;
  std::vector<PrimitiveRef> candidates;
  world.primitives_near(pose.position() - Point2d::Constant(r),
                        pose.position() + Point2d::Constant(r), candidates);
  for (const PrimitiveRef& ref : candidates) {
    switch (ref.kind) {
      case SurfaceKind::wall: {
        const Wall& w = world.walls()[ref.index];
        if (band(0, w.height)) visit(ref, Segment(footprint_point(w.a), footprint_point(w.b)), 0.0);
        break;
      }
      case SurfaceKind::box: {
        const Box& b = world.boxes()[ref.index];
        if (band(b.z_min, b.z_max)) visit(ref, footprint_rect(b.center, b.size / 2, b.yaw), 0.0);
        break;
      }
      case SurfaceKind::cylinder: {
        const Cylinder& c = world.cylinders()[ref.index];
        if (band(c.z_min, c.z_max)) visit(ref, footprint_point(c.center), c.radius);
        break;
      }
      case SurfaceKind::door: {
        const Box b = world.doors()[ref.index].leaf();
        if (band(b.z_min, b.z_max)) visit(ref, footprint_rect(b.center, b.size / 2, b.yaw), 0.0);
        break;
      }
      case SurfaceKind::hole: {
        const FloorHole& h = world.holes()[ref.index];
        visit(ref, footprint_rect(h.center, h.size / 2, h.yaw), 0.0);
        break;
      }
      default:
        break;
    }
  }
}
}  // namespace footprint_geometry

/// The primitives a footprint at a pose touches (holes: the footprint is over a lowered floor).
[[nodiscard]] inline std::vector<PrimitiveRef> footprint_contacts(const World& world,
                                                                  const Footprint& fp,
                                                                  const Pose2d& pose) {
  const footprint_geometry::PlacedFootprint placed(fp, pose);
  std::vector<PrimitiveRef> contacts;
  footprint_geometry::for_each_primitive_near(
      world, fp, pose, 0.0, [&](const PrimitiveRef& ref, const auto& geometry, double grow) {
        if (placed.touches(geometry, grow)) contacts.push_back(ref);
      });
  return contacts;
}

/// The true clearance of a footprint at a pose: the smallest distance (m) from the footprint to any
/// primitive in its height band (walls, boxes, cylinders, door leaves, and floor holes at any
/// height), 0 when it touches one, `max_distance` when nothing is nearer than that. The
/// ground truth for "how close did the robot come" (footprint_contacts says only whether).
[[nodiscard]] inline double footprint_clearance(const World& world, const Footprint& fp,
                                                const Pose2d& pose, double max_distance = 1.0) {
  const footprint_geometry::PlacedFootprint placed(fp, pose);
  double best = max_distance;
  footprint_geometry::for_each_primitive_near(
      world, fp, pose, max_distance, [&](const PrimitiveRef&, const auto& geometry, double grow) {
        best = std::min(best, std::max(0.0, placed.distance(geometry, grow)));
      });
  return best;
}

/// Systematic and random odometry errors. The wheel odometry measures
///   v_m = (1 + v_scale) v + N(0, v_sigma^2),  omega_m = (1 + omega_scale) omega + omega_bias +
///   N(0, omega_sigma^2)
/// once per control step and integrates them like the true motion.
struct OdometryNoise {
  double v_scale{0.0};      ///< relative scale error of the travelled distance
  double omega_scale{0.0};  ///< relative scale error of the turn rate
  double omega_bias{0.0};   ///< rad/s (drift)
  double v_sigma{0.0};      ///< m/s per step
  double omega_sigma{0.0};  ///< rad/s per step
};

/// Parameters of the simulated differential-drive robot.
struct DifferentialDriveParams {
  double control_rate{50.0};  ///< Hz
  double max_v{1.0};          ///< |v| is clamped to this (m/s)
  double max_omega{2.0};      ///< |omega| is clamped to this (rad/s)
  Footprint footprint{};      ///< what the robot may touch
  OdometryNoise odometry{};   ///< odometry errors
};

/// What one control step did.
struct StepResult {
  bool moved{true};                    ///< false when the step would have hit something
  std::vector<PrimitiveRef> contacts;  ///< what the robot would touch at the step's end
  double v_measured{0};                ///< odometry's velocity reading for this step
  double omega_measured{0};            ///< odometry's angular-velocity reading for this step
};

/// A differential-drive robot: (v, omega) steps integrated exactly along arcs, odometry with
/// errors, and a footprint that stops a step before it touches the world.
class DifferentialDriveRobot {
 public:
  /// A robot at `start` (its odometry starts there too); throws invalid_argument for invalid
  /// parameters.
  explicit DifferentialDriveRobot(const DifferentialDriveParams& params = {},
                                  const Pose2d& start = {})
      : params_(params) {
    constexpr std::string_view where = "DifferentialDriveRobot";
    detail::require_positive(where, "control_rate", params_.control_rate);
    detail::require_positive(where, "max_v", params_.max_v);
    detail::require_positive(where, "max_omega", params_.max_omega);
    params_.footprint.validate(where);
    const auto& o = params_.odometry;
    detail::require_finite(where, "odometry.v_scale", o.v_scale);
    detail::require_finite(where, "odometry.omega_scale", o.omega_scale);
    detail::require_finite(where, "odometry.omega_bias", o.omega_bias);
    detail::require_non_negative(where, "odometry.v_sigma", o.v_sigma);
    detail::require_non_negative(where, "odometry.omega_sigma", o.omega_sigma);
    reset(start);
  }

  /// Puts the robot at `pose` (odometry restarts there too) at time 0.
  void reset(const Pose2d& pose) {
    if (!(std::isfinite(pose.x) && std::isfinite(pose.y) && std::isfinite(pose.theta)))
      detail::throw_invalid("DifferentialDriveRobot::reset", "pose must be finite");
    pose_ = {pose.x, pose.y, normalize_angle(pose.theta)};
    odometry_ = pose_;
    time_ = 0;
  }

  /// The parameters.
  [[nodiscard]] const DifferentialDriveParams& params() const { return params_; }
  /// The true pose (world frame).
  [[nodiscard]] const Pose2d& pose() const { return pose_; }
  /// The pose odometry reports (starts at the start pose, drifts).
  [[nodiscard]] const Pose2d& odometry() const { return odometry_; }
  /// Simulated time (s).
  [[nodiscard]] double time() const { return time_; }
  /// The control period, 1 / control_rate (s).
  [[nodiscard]] double dt() const { return 1.0 / params_.control_rate; }

  /// The unicycle model integrated exactly over dt (an arc, or a line when omega = 0).
  [[nodiscard]] static Pose2d integrate(const Pose2d& p, double v, double omega, double dt) {
    const double th1 = p.theta + omega * dt;
    if (std::abs(omega) < 1e-12)
      return {p.x + v * dt * std::cos(p.theta), p.y + v * dt * std::sin(p.theta),
              normalize_angle(th1)};
    const double r = v / omega;
    return {p.x + r * (std::sin(th1) - std::sin(p.theta)),
            p.y - r * (std::cos(th1) - std::cos(p.theta)), normalize_angle(th1)};
  }

  /// The primitives the footprint touches at `pose`.
  [[nodiscard]] std::vector<PrimitiveRef> contacts(const World& world, const Pose2d& pose) const {
    return footprint_contacts(world, params_.footprint, pose);
  }

  /// One control step with command (v, omega), clamped to the limits. When the new pose would
  /// touch something the robot stays where it is (and so does its odometry).
  template <class Engine>
  StepResult step(const World& world, double v, double omega, Engine& rng) {
    StepResult result;
    if (!std::isfinite(v)) v = 0;
    if (!std::isfinite(omega)) omega = 0;
    v = std::clamp(v, -params_.max_v, params_.max_v);
    omega = std::clamp(omega, -params_.max_omega, params_.max_omega);
    const double h = dt();
    time_ += h;
    const Pose2d next = integrate(pose_, v, omega, h);
    result.contacts = contacts(world, next);
    if (!result.contacts.empty()) {
      result.moved = false;
      return result;
    }
    pose_ = next;
    const auto& o = params_.odometry;
    double vm = (1 + o.v_scale) * v, wm = (1 + o.omega_scale) * omega + o.omega_bias;
    if (o.v_sigma > 0) vm += std::normal_distribution<double>(0.0, o.v_sigma)(rng);
    if (o.omega_sigma > 0) wm += std::normal_distribution<double>(0.0, o.omega_sigma)(rng);
    odometry_ = integrate(odometry_, vm, wm, h);
    result.v_measured = vm;
    result.omega_measured = wm;
    return result;
  }

 private:
  DifferentialDriveParams params_;
  Pose2d pose_{};
  Pose2d odometry_{};
  double time_{0};
};

}  // namespace rangenav::sim
