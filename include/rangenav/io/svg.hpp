#pragma once
// SvgDrawing: 2D drawings of maps, scans, poses and trajectories as SVG files.
//
// Everything is drawn in world coordinates (metres, x right, y up); the drawing keeps the shapes
// and lays them out when it is written: the view box fits everything drawn plus a margin, the
// longer side of the drawing area is SvgOptions::size_px pixels, and a footer below it holds a
// scale bar (a round length of 1, 2 or 5 x 10^k metres, with its label) and a legend of the
// named layers in their colours.
//
// The file's user units are metres with y negated (SVG's y points down), so a coordinate read
// in the file is the world coordinate, up to the sign of y; numbers are written with as many
// decimals as a tenth of a pixel needs, which keeps a 100k-point drawing near 2 MB. Line widths,
// point radii and font sizes are given in pixels and do not depend on the zoom. Text and the
// footer are written in pixel units under a `translate(..) scale(1/pixels-per-metre)` transform:
// renderers such as librsvg garble glyphs whose font size is a fraction of a user unit.
//
//   rangenav::io::SvgDrawing svg;
//   svg.layer("map").points(map_cloud, {.stroke = "#444"});
//   svg.layer("trajectory").path(poses, {.stroke = "crimson", .stroke_width_px = 2});
//   svg.save("map.svg");  // throws io_error when the file cannot be written
//
// Non-finite points inside clouds, polylines and trajectories are skipped (a polyline or a
// trajectory is split there); a single shape with a non-finite coordinate, a negative radius or
// a bad style throws invalid_argument.

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "rangenav/core/error.hpp"
#include "rangenav/core/point_cloud.hpp"
#include "rangenav/core/types.hpp"

namespace rangenav::io {

/// How a shape is painted. Colours are any SVG colour ("red", "#1f77b4", "none"); sizes are in
/// pixels of the output picture.
struct Style {
  std::string stroke = "black";  ///< line colour; also the colour of points and (fill "none") text
  std::string fill = "none";     ///< area colour of polygons, circles and arrow heads
  double stroke_width_px = 1.0;  ///< line width, >= 0
  double opacity = 1.0;          ///< in [0, 1]
  double point_radius_px = 1.5;  ///< radius of the dots drawn by points(), > 0
};

/// Layout of the picture.
struct SvgOptions {
  double size_px = 1000.0;           ///< the longer side of the drawing area (without footer)
  double margin_px = 20.0;           ///< blank border around the drawn content, >= 0
  std::string background = "white";  ///< "none" for a transparent picture
  bool scale_bar = true;             ///< a scale bar in metres in the footer
  bool legend = true;                ///< the named layers and their colours in the footer
};

namespace detail {

/// Appends `text` with the five XML special characters escaped; control characters that XML 1.0
/// forbids are replaced by '?'.
inline void append_escaped(std::string& out, std::string_view text) {
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20 && c != '\t' && c != '\n' && c != '\r')
          out += '?';
        else
          out += c;
    }
  }
}

[[nodiscard]] inline std::string escape_xml(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  append_escaped(out, text);
  return out;
}

/// Appends `value` in fixed notation with at most `decimals` decimals, without trailing zeros
/// ("1.5", "-2", "0").
inline void append_number(std::string& out, double value, int decimals) {
  std::array<char, 64> buffer{};
  auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value,
                              std::chars_format::fixed, decimals);
  char* end = result.ptr;
  if (result.ec != std::errc{}) {  // |value| beyond 1e40: not a useful coordinate anyway
    end = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value).ptr;
  } else if (decimals > 0) {
    while (end[-1] == '0')
      --end;
    if (end[-1] == '.') --end;
  }
  std::string_view text(buffer.data(), static_cast<std::size_t>(end - buffer.data()));
  if (text == "-0") text = "0";
  out += text;
}

/// The largest length 1, 2 or 5 x 10^k metres that is at most `max_length_m` (> 0).
[[nodiscard]] inline double nice_length_at_most(double max_length_m) {
  const double decade = std::pow(10.0, std::floor(std::log10(max_length_m)));
  for (const double m : {5.0, 2.0}) {
    if (m * decade <= max_length_m * (1 + 1e-12)) return m * decade;
  }
  return decade;
}

/// "2 m", "50 cm", "5 mm", "10 km".
[[nodiscard]] inline std::string length_label(double length_m) {
  std::string out;
  if (length_m >= 1000.0) {
    append_number(out, length_m / 1000.0, 6);
    out += " km";
  } else if (length_m >= 1.0) {
    append_number(out, length_m, 6);
    out += " m";
  } else if (length_m >= 0.01) {
    append_number(out, length_m * 100.0, 6);
    out += " cm";
  } else {
    append_number(out, length_m * 1000.0, 6);
    out += " mm";
  }
  return out;
}

/// A name usable as an XML id: letters, digits, '-' and '_' kept, anything else '_'.
[[nodiscard]] inline std::string xml_id(std::string_view name) {
  std::string id;
  for (const char c : name) {
    const bool keep = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                      c == '-' || c == '_';
    id += keep ? c : '_';
  }
  if (id.empty() || !((id[0] >= 'a' && id[0] <= 'z') || (id[0] >= 'A' && id[0] <= 'Z')))
    id.insert(0, "layer_");
  return id;
}

}  // namespace detail

/// An SVG drawing assembled from shapes in world coordinates (see the file comment).
class SvgDrawing {
 public:
  /// An empty drawing; throws invalid_argument for a negative margin, or a size_px that is not
  /// finite or too small for the margins (< 2 * margin_px + 10).
  explicit SvgDrawing(SvgOptions options = {}) : options_(std::move(options)) {
    rangenav::detail::require_non_negative("SvgDrawing", "options.margin_px", options_.margin_px);
    if (!(std::isfinite(options_.size_px) && options_.size_px >= 2 * options_.margin_px + 10))
      rangenav::detail::throw_invalid_argument(
          "SvgDrawing", "options.size_px", options_.size_px,
          "must be finite and >= 2 * margin_px + 10 = " +
              rangenav::detail::format_value(2 * options_.margin_px + 10));
  }

  /// Starts the layer `name`, or selects it again if it exists: later shapes go into it. Layers
  /// are written (and stacked) in the order they were first named, as `<g id="name">`; shapes
  /// drawn before the first call go into an unnamed bottom layer that the legend leaves out.
  SvgDrawing& layer(std::string name) {
    if (name.empty())
      rangenav::detail::throw_invalid("SvgDrawing::layer", "the layer name is empty");
    for (std::size_t i = 0; i < layers_.size(); ++i) {
      if (layers_[i].name == name && !layers_[i].unnamed) {
        current_ = i;
        return *this;
      }
    }
    std::string id = detail::xml_id(name);
    for (int suffix = 2; has_id(id); ++suffix)
      id = detail::xml_id(name) + "_" + std::to_string(suffix);
    layers_.push_back({std::move(name), std::move(id), false});
    current_ = layers_.size() - 1;
    return *this;
  }

  /// One dot of radius style.point_radius_px (in the stroke colour) per finite point of any 2D
  /// or 3D PointCloud (3D points are drawn at their x, y).
  template <PointCloud C>
  SvgDrawing& points(const C& cloud, const Style& style = {}) {
    check_style("SvgDrawing::points", style);
    Element e{Kind::points, current_layer(), style};
    const std::size_t n = traits::size(cloud);
    e.pts.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
      const auto p = xy(traits::point(cloud, i));
      if (p.allFinite()) e.pts.push_back(p);
    }
    if (!e.pts.empty()) add(std::move(e));
    return *this;
  }

  /// A line through the points of a 2D or 3D PointCloud in order; a non-finite point splits it.
  template <PointCloud C>
  SvgDrawing& polyline(const C& vertices, const Style& style = {}) {
    check_style("SvgDrawing::polyline", style);
    std::vector<Point2d> run;
    const std::size_t n = traits::size(vertices);
    for (std::size_t i = 0; i <= n; ++i) {
      const Point2d p = i < n ? xy(traits::point(vertices, i)) : Point2d::Constant(nan());
      if (p.allFinite()) {
        run.push_back(p);
      } else {
        if (run.size() >= 2) add({Kind::polyline, current_layer(), style, std::move(run)});
        run.clear();
      }
    }
    return *this;
  }

  /// A closed polygon through the finite vertices (fewer than two draw nothing).
  template <PointCloud C>
  SvgDrawing& polygon(const C& vertices, const Style& style = {}) {
    check_style("SvgDrawing::polygon", style);
    Element e{Kind::polygon, current_layer(), style};
    const std::size_t n = traits::size(vertices);
    for (std::size_t i = 0; i < n; ++i) {
      const Point2d p = xy(traits::point(vertices, i));
      if (p.allFinite()) e.pts.push_back(p);
    }
    if (e.pts.size() >= 2) add(std::move(e));
    return *this;
  }

  /// The segment from a to b.
  SvgDrawing& segment(const Point2d& a, const Point2d& b, const Style& style = {}) {
    check_style("SvgDrawing::segment", style);
    require_finite_point("SvgDrawing::segment", "a", a);
    require_finite_point("SvgDrawing::segment", "b", b);
    add({Kind::segment, current_layer(), style, {a, b}});
    return *this;
  }

  /// A circle of radius `radius_m` metres (>= 0) around `center`.
  SvgDrawing& circle(const Point2d& center, double radius_m, const Style& style = {}) {
    check_style("SvgDrawing::circle", style);
    require_finite_point("SvgDrawing::circle", "center", center);
    rangenav::detail::require_non_negative("SvgDrawing::circle", "radius_m", radius_m);
    add({Kind::circle, current_layer(), style, {center}, radius_m});
    return *this;
  }

  /// An arrow of `length_m` metres (> 0) from the pose's position along its heading; with a
  /// fill colour the arrow head is a filled triangle.
  SvgDrawing& pose(const Pose2d& pose, double length_m, const Style& style = {}) {
    check_style("SvgDrawing::pose", style);
    rangenav::detail::require_positive("SvgDrawing::pose", "length_m", length_m);
    if (!(std::isfinite(pose.x) && std::isfinite(pose.y) && std::isfinite(pose.theta)))
      rangenav::detail::throw_invalid_argument(
          "SvgDrawing::pose", "pose", tuple_text(pose.x, pose.y, pose.theta), "must be finite");
    Element e{Kind::arrows, current_layer(), style};
    append_arrow(e, pose, length_m);
    add(std::move(e));
    return *this;
  }

  /// One arrow (as pose()) per finite pose, written as a single SVG path.
  SvgDrawing& poses(std::span<const Pose2d> poses, double length_m, const Style& style = {}) {
    check_style("SvgDrawing::poses", style);
    rangenav::detail::require_positive("SvgDrawing::poses", "length_m", length_m);
    Element e{Kind::arrows, current_layer(), style};
    for (const Pose2d& p : poses) {
      if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.theta))
        append_arrow(e, p, length_m);
    }
    if (!e.pts.empty()) add(std::move(e));
    return *this;
  }

  /// A trajectory: the polyline through the poses' positions (split at non-finite positions).
  SvgDrawing& path(std::span<const Pose2d> poses, const Style& style = {}) {
    check_style("SvgDrawing::path", style);
    std::vector<Point2d> positions;
    positions.reserve(poses.size());
    for (const Pose2d& p : poses) {
      positions.emplace_back(p.x, p.y);
    }
    return polyline(positions, style);
  }

  /// `content` written at `at` (its baseline starts there) with a font size of `size_px` pixels,
  /// in the fill colour, or the stroke colour when the fill is "none".
  SvgDrawing& text(const Point2d& at, std::string_view content, double size_px = 12.0,
                   const Style& style = {}) {
    check_style("SvgDrawing::text", style);
    require_finite_point("SvgDrawing::text", "at", at);
    rangenav::detail::require_positive("SvgDrawing::text", "size_px", size_px);
    Element e{Kind::text, current_layer(), style, {at}, size_px};
    e.text = std::string(content);
    add(std::move(e));
    return *this;
  }

  /// Number of SVG elements the shapes drawn so far become (scale bar and legend excluded).
  [[nodiscard]] std::size_t element_count() const { return elements_.size(); }
  /// True when no shape has been drawn yet.
  [[nodiscard]] bool empty() const { return elements_.empty(); }

  /// The SVG document.
  [[nodiscard]] std::string str() const {
    const Frame f = frame();
    std::string out;
    out.reserve(1024 + point_count_ * 20);
    out += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
    out += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"";
    detail::append_number(out, f.width_px, 0);
    out += "\" height=\"";
    detail::append_number(out, f.height_px, 0);
    out += "\" viewBox=\"";  // a hundredth of a pixel: the frame must not drift
    size(out, f, f.x0 * f.scale);
    out += ' ';
    size(out, f, f.y0 * f.scale);
    out += ' ';
    size(out, f, f.width_px);
    out += ' ';
    size(out, f, f.height_px);
    out += "\" font-family=\"sans-serif\" stroke-linecap=\"round\" stroke-linejoin=\"round\">\n";
    if (options_.background != "none") {
      out += "<rect x=\"";  // exactly the view box
      size(out, f, f.x0 * f.scale);
      out += "\" y=\"";
      size(out, f, f.y0 * f.scale);
      out += "\" width=\"";
      size(out, f, f.width_px);
      out += "\" height=\"";
      size(out, f, f.height_px);
      out += "\" fill=\"";
      detail::append_escaped(out, options_.background);
      out += "\"/>\n";
    }
    for (std::size_t l = 0; l < layers_.size(); ++l) {
      out += "<g id=\"";
      out += layers_[l].id;  // already a valid id
      out += "\">\n";
      for (const Element& e : elements_) {
        if (e.layer == l) write(out, f, e);
      }
      out += "</g>\n";
    }
    if (!elements_.empty()) write_footer(out, f);
    out += "</svg>\n";
    return out;
  }

  /// Writes str() to `file` (its directory must exist); throws io_error naming the file when it
  /// cannot be written.
  void save(const std::filesystem::path& file) const {
    const std::string text = str();
    std::ofstream stream(file, std::ios::binary | std::ios::trunc);
    if (!stream)
      throw io_error("rangenav: SvgDrawing::save: cannot open '" + file.string() + "' for writing");
    stream.write(text.data(), static_cast<std::streamsize>(text.size()));
    stream.close();
    if (!stream)
      throw io_error("rangenav: SvgDrawing::save: writing '" + file.string() + "' failed");
  }

 private:
  enum class Kind { points, polyline, polygon, segment, circle, arrows, text };

  struct Element {
    Kind kind;
    std::size_t layer;
    Style style;
    std::vector<Point2d> pts{};  // arrows: (tail, tip, barb, barb) per arrow
    double value = 0;            // circle: radius (m); text: font size (px)
    std::string text{};
  };

  struct Layer {
    std::string name;
    std::string id;
    bool unnamed;
  };

  /// The mapping from world metres to the file: user unit = metre, y negated, `scale` pixels per
  /// metre; (x0, y0) is the top-left corner of the view box in user units.
  struct Frame {
    double scale;
    double x0;
    double y0;
    double width_px;
    double height_px;
    double drawing_height_px;  // the footer starts here
    int decimals;              // enough for a tenth of a pixel
    double scale_bar_m;
  };

  static constexpr std::size_t scale_bar_slot = std::numeric_limits<std::size_t>::max();
  static constexpr double font_px = 12.0;  // footer text
  static constexpr double row_px = 20.0;   // footer row height
  static constexpr double char_px = 7.0;   // estimated width of a footer character

  static double nan() { return std::numeric_limits<double>::quiet_NaN(); }

  template <class P>
  static Point2d xy(const P& p) {
    return {static_cast<double>(p[0]), static_cast<double>(p[1])};
  }

  // "(1, 2, 3)"; appended piecewise (g++ 12 warns falsely on chained string operator+).
  template <class... T>
  static std::string tuple_text(const T&... values) {
    std::string out = "(";
    ((out.append(rangenav::detail::format_value(values)).append(", ")), ...);
    out.resize(out.size() - 2);
    out += ')';
    return out;
  }

  static void require_finite_point(std::string_view where, std::string_view name,
                                   const Point2d& p) {
    if (!p.allFinite())
      rangenav::detail::throw_invalid_argument(where, name, tuple_text(p.x(), p.y()),
                                               "must be finite");
  }

  static void check_style(std::string_view where, const Style& style) {
    rangenav::detail::require_non_negative(where, "style.stroke_width_px", style.stroke_width_px);
    rangenav::detail::require_positive(where, "style.point_radius_px", style.point_radius_px);
    if (!(style.opacity >= 0.0 && style.opacity <= 1.0))
      rangenav::detail::throw_invalid_argument(where, "style.opacity", style.opacity,
                                               "must be in [0, 1]");
  }

  static void append_arrow(Element& e, const Pose2d& p, double length_m) {
    // Head: two barbs of 30% of the length, 25 degrees off the shaft.
    const double head = 0.3 * length_m;
    const double spread = 25.0 * std::numbers::pi / 180.0;
    const Point2d tail(p.x, p.y);
    const Point2d tip = tail + length_m * Point2d(std::cos(p.theta), std::sin(p.theta));
    const auto barb = [&](double side) {
      const double a = p.theta + std::numbers::pi + side * spread;
      return Point2d(tip + head * Point2d(std::cos(a), std::sin(a)));
    };
    e.pts.insert(e.pts.end(), {tail, tip, barb(1.0), barb(-1.0)});
  }

  bool has_id(const std::string& id) const {
    return std::any_of(layers_.begin(), layers_.end(), [&](const Layer& l) { return l.id == id; });
  }

  std::size_t current_layer() {
    if (layers_.empty()) {
      layers_.push_back({"", "layer_unnamed", true});
      current_ = 0;
    }
    return current_;
  }

  void add(Element e) {
    for (const Point2d& p : e.pts) {
      lo_ = lo_.cwiseMin(p - Point2d::Constant(e.kind == Kind::circle ? e.value : 0.0));
      hi_ = hi_.cwiseMax(p + Point2d::Constant(e.kind == Kind::circle ? e.value : 0.0));
    }
    point_count_ += e.pts.size();
    elements_.push_back(std::move(e));
  }

  /// The layout: the longer side of the content gets size_px - 2 margin_px pixels.
  Frame frame() const {
    Point2d lo = lo_, hi = hi_;
    if (elements_.empty()) {
      lo = Point2d(0, 0);
      hi = Point2d(1, 1);
    }
    double extent = (hi - lo).maxCoeff();
    if (!(extent > 1e-9)) {  // a single point: show a metre around it
      lo -= Point2d(0.5, 0.5);
      hi += Point2d(0.5, 0.5);
      extent = 1.0;
    }
    Frame f{};
    const double m = options_.margin_px;
    f.scale = (options_.size_px - 2 * m) / extent;
    f.decimals = std::clamp(static_cast<int>(std::ceil(std::log10(10.0 * f.scale))), 0, 12);
    f.scale_bar_m = detail::nice_length_at_most(extent / 4);
    const double content_width_px = (hi.x() - lo.x()) * f.scale + 2 * m;
    f.drawing_height_px = (hi.y() - lo.y()) * f.scale + 2 * m;
    f.width_px = std::ceil(std::max(content_width_px, footer_min_width_px(f)));
    const int rows = footer_rows(f);
    f.height_px = std::ceil(f.drawing_height_px + (rows > 0 ? rows * row_px + m / 2 : 0.0));
    const double extra_px = (f.width_px - content_width_px) / 2;  // centre narrow content
    f.x0 = lo.x() - (m + extra_px) / f.scale;
    f.y0 = -hi.y() - m / f.scale;
    return f;
  }

  bool has_footer() const { return !elements_.empty() && (options_.scale_bar || options_.legend); }

  std::vector<std::size_t> legend_layers() const {
    std::vector<std::size_t> out;
    if (!options_.legend) return out;
    for (std::size_t l = 0; l < layers_.size(); ++l) {
      if (layers_[l].unnamed) continue;
      if (std::any_of(elements_.begin(), elements_.end(),
                      [&](const Element& e) { return e.layer == l; }))
        out.push_back(l);
    }
    return out;
  }

  double scale_bar_width_px(const Frame& f) const {
    if (!options_.scale_bar) return 0.0;
    return f.scale_bar_m * f.scale + 6 +
           char_px * static_cast<double>(detail::length_label(f.scale_bar_m).size()) + 24;
  }

  static double legend_item_width_px(const Layer& l) {
    return 22 + char_px * static_cast<double>(l.name.size()) + 18;
  }

  // The footer is at least as wide as the scale bar and the widest legend item.
  double footer_min_width_px(const Frame& f) const {
    if (!has_footer()) return 0.0;
    double w = scale_bar_width_px(f);
    for (const std::size_t l : legend_layers())
      w = std::max(w, legend_item_width_px(layers_[l]));
    return w + 2 * options_.margin_px;
  }

  /// Walks the footer left to right, wrapping rows; calls place(layer or npos, x_px, row).
  template <class Place>
  int layout_footer(const Frame& f, Place&& place) const {
    if (!has_footer()) return 0;
    const double left = options_.margin_px, right = f.width_px - options_.margin_px;
    double x = left;
    int row = 0;
    if (options_.scale_bar) {
      place(scale_bar_slot, x, row);
      x += scale_bar_width_px(f);
    }
    for (const std::size_t l : legend_layers()) {
      const double w = legend_item_width_px(layers_[l]);
      if (x > left && x + w > right + 18) {
        x = left;
        ++row;
      }
      place(l, x, row);
      x += w;
    }
    return x > left || row > 0 ? row + 1 : 0;
  }

  int footer_rows(const Frame& f) const {
    return layout_footer(f, [](std::size_t, double, int) {});
  }

  void num(std::string& out, const Frame& f, double v) const {
    detail::append_number(out, v, f.decimals);
  }
  // A size (pixels) in user units, two more decimals than coordinates.
  void size(std::string& out, const Frame& f, double px) const {
    detail::append_number(out, px / f.scale, f.decimals + 2);
  }
  void xy_attr(std::string& out, const Frame& f, const Point2d& p, const char* xname,
               const char* yname) const {
    out += ' ';
    out += xname;
    out += "=\"";
    num(out, f, p.x());
    out += "\" ";
    out += yname;
    out += "=\"";
    num(out, f, -p.y());
    out += '"';
  }
  void coords(std::string& out, const Frame& f, const Point2d& p) const {
    num(out, f, p.x());
    out += ' ';
    num(out, f, -p.y());
  }

  void paint(std::string& out, const Frame& f, const std::string& stroke, const std::string& fill,
             double stroke_width_px, double opacity) const {
    out += " stroke=\"";
    detail::append_escaped(out, stroke);
    out += "\" fill=\"";
    detail::append_escaped(out, fill);
    out += '"';
    if (stroke != "none") {
      out += " stroke-width=\"";
      size(out, f, stroke_width_px);
      out += '"';
    }
    if (opacity < 1.0) {
      out += " opacity=\"";
      detail::append_number(out, opacity, 3);
      out += '"';
    }
  }

  void write(std::string& out, const Frame& f, const Element& e) const {
    const Style& s = e.style;
    switch (e.kind) {
      case Kind::points: {
        // One path of zero-length round-capped segments: a dot per point in ~20 bytes.
        out += "<path d=\"";
        for (const Point2d& p : e.pts) {
          out += 'M';
          coords(out, f, p);
          out += "h0";
        }
        out += '"';
        paint(out, f, s.stroke, "none", 2 * s.point_radius_px, s.opacity);
        out += "/>\n";
        break;
      }
      case Kind::polyline:
      case Kind::polygon: {
        out += e.kind == Kind::polyline ? "<polyline points=\"" : "<polygon points=\"";
        for (std::size_t i = 0; i < e.pts.size(); ++i) {
          if (i > 0) out += ' ';
          num(out, f, e.pts[i].x());
          out += ',';
          num(out, f, -e.pts[i].y());
        }
        out += '"';
        paint(out, f, s.stroke, e.kind == Kind::polyline ? std::string("none") : s.fill,
              s.stroke_width_px, s.opacity);
        out += "/>\n";
        break;
      }
      case Kind::segment:
        out += "<line";
        xy_attr(out, f, e.pts[0], "x1", "y1");
        xy_attr(out, f, e.pts[1], "x2", "y2");
        paint(out, f, s.stroke, "none", s.stroke_width_px, s.opacity);
        out += "/>\n";
        break;
      case Kind::circle:
        out += "<circle";
        xy_attr(out, f, e.pts[0], "cx", "cy");
        out += " r=\"";
        num(out, f, e.value);
        out += '"';
        paint(out, f, s.stroke, s.fill, s.stroke_width_px, s.opacity);
        out += "/>\n";
        break;
      case Kind::arrows: {
        out += "<path d=\"";
        const bool filled = s.fill != "none";
        for (std::size_t i = 0; i + 3 < e.pts.size(); i += 4) {
          out += 'M';
          coords(out, f, e.pts[i]);
          out += 'L';
          coords(out, f, e.pts[i + 1]);
          out += 'M';
          coords(out, f, e.pts[i + 2]);
          out += 'L';
          coords(out, f, e.pts[i + 1]);
          out += 'L';
          coords(out, f, e.pts[i + 3]);
          if (filled) out += 'Z';
        }
        out += '"';
        paint(out, f, s.stroke, s.fill, s.stroke_width_px, s.opacity);
        out += "/>\n";
        break;
      }
      case Kind::text: {
        out += "<text ";
        pixel_frame(out, f, e.pts[0].x(), -e.pts[0].y());
        out += " font-size=\"";
        detail::append_number(out, e.value, 2);
        out += '"';
        paint(out, f, "none", s.fill != "none" ? s.fill : s.stroke, 0.0, s.opacity);
        out += '>';
        detail::append_escaped(out, e.text);
        out += "</text>\n";
        break;
      }
    }
  }

  // "translate(x y) scale(1/scale)": the frame of pixel-sized content (text, footer) placed at
  // the user-space point (x, y). Renderers hint glyphs at the font size they are given, so text
  // is never written with a font size of a fraction of a user unit.
  void pixel_frame(std::string& out, const Frame& f, double x, double y) const {
    out += "transform=\"translate(";
    num(out, f, x);
    out += ' ';
    num(out, f, y);
    out += ") scale(";
    detail::append_number(out, 1.0 / f.scale, f.decimals + 5);
    out += ")\"";
  }

  // The footer is drawn in pixels from the picture's top-left corner.
  void write_footer(std::string& out, const Frame& f) const {
    const auto px = [](std::string& to, double v) { detail::append_number(to, v, 1); };
    const auto text_at = [&](std::string& to, double x, double y, std::string_view content) {
      to += "<text x=\"";
      px(to, x);
      to += "\" y=\"";
      px(to, y);
      to += "\">";
      detail::append_escaped(to, content);
      to += "</text>\n";
    };
    std::string scale_bar, legend;
    layout_footer(f, [&](std::size_t l, double x, int row) {
      const double y = f.drawing_height_px + (row + 0.5) * row_px;  // middle of the row
      if (l == scale_bar_slot) {
        // |------| with end ticks, then its label.
        const double x_end = x + f.scale_bar_m * f.scale;
        scale_bar += "<path d=\"M";
        px(scale_bar, x);
        scale_bar += ' ';
        px(scale_bar, y - 4);
        scale_bar += "v8M";
        px(scale_bar, x);
        scale_bar += ' ';
        px(scale_bar, y);
        scale_bar += 'H';
        px(scale_bar, x_end);
        scale_bar += 'M';
        px(scale_bar, x_end);
        scale_bar += ' ';
        px(scale_bar, y - 4);
        scale_bar += "v8\" stroke=\"black\" stroke-width=\"2\" fill=\"none\"/>\n";
        text_at(scale_bar, x_end + 6, y + 4, detail::length_label(f.scale_bar_m));
        return;
      }
      // A swatch that looks like the layer's first shape: a dot for points, a filled box for
      // filled areas, else a thick line; then the layer's name.
      const Element& first = *std::find_if(elements_.begin(), elements_.end(),
                                           [&](const Element& e) { return e.layer == l; });
      const Style& style = first.style;
      const bool area =
          (first.kind == Kind::polygon || first.kind == Kind::circle) && style.fill != "none";
      if (area) {
        legend += "<rect x=\"";
        px(legend, x + 1);
        legend += "\" y=\"";
        px(legend, y - 5);
        legend += "\" width=\"14\" height=\"10\" fill=\"";
        detail::append_escaped(legend, style.fill);
        legend += "\" stroke=\"";
        detail::append_escaped(legend, style.stroke);
        legend += '"';
      } else {
        const bool dot = first.kind == Kind::points;
        legend += "<path d=\"M";
        px(legend, dot ? x + 8 : x);
        legend += ' ';
        px(legend, y);
        legend += dot ? "h0" : "h16";
        legend += "\" stroke=\"";
        detail::append_escaped(legend, style.stroke != "none" ? style.stroke : style.fill);
        legend += dot ? "\" stroke-width=\"7\"" : "\" stroke-width=\"4\"";
        legend += " fill=\"none\"";
      }
      if (style.opacity < 1.0) {
        legend += " opacity=\"";
        detail::append_number(legend, std::max(style.opacity, 0.3), 3);
        legend += '"';
      }
      legend += "/>\n";
      text_at(legend, x + 22, y + 4, layers_[l].name);
    });
    out += "<g id=\"footer\" ";
    pixel_frame(out, f, f.x0, f.y0);
    out += " font-size=\"";
    px(out, font_px);
    out += "\" fill=\"black\">\n";
    if (!scale_bar.empty()) out.append("<g id=\"scale-bar\">\n").append(scale_bar).append("</g>\n");
    if (!legend.empty()) out.append("<g id=\"legend\">\n").append(legend).append("</g>\n");
    out += "</g>\n";
  }

  SvgOptions options_;
  std::vector<Layer> layers_;
  std::size_t current_ = 0;
  std::vector<Element> elements_;
  Point2d lo_ = Point2d::Constant(std::numeric_limits<double>::infinity());
  Point2d hi_ = Point2d::Constant(-std::numeric_limits<double>::infinity());
  std::size_t point_count_ = 0;
};

}  // namespace rangenav::io
