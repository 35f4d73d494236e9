#pragma once
// small_gicp's KITTI pair (two lidar scans) and its ground truth, for the registration tests
// that score a method against it.

#include <optional>

#include "rangenav/core/cloud.hpp"
#include "rangenav/core/types.hpp"
#include "rangenav/io/ply.hpp"
#include "rangenav/io/trajectory.hpp"
#include "test_support.hpp"

namespace rangenav::test {

/// The pair as read (no filter): `truth` maps source points into the target's frame.
struct KittiPair {
  Cloud3d source;
  Cloud3d target;
  Transform3d truth;
};

/// small_gicp/source.ply, target.ply and T_target_source.txt from the shared data, or nothing
/// after the visible skip when one of them is missing.
inline std::optional<KittiPair> kitti_pair_or_skip() {
  const auto source_path = data_file_or_skip("small_gicp/source.ply");
  const auto target_path = data_file_or_skip("small_gicp/target.ply");
  const auto truth_path = data_file_or_skip("small_gicp/T_target_source.txt");
  if (source_path.empty() || target_path.empty() || truth_path.empty()) return std::nullopt;
  return KittiPair{io::read_ply<double>(source_path), io::read_ply<double>(target_path),
                   io::read_transform_matrix(truth_path)};
}

}  // namespace rangenav::test
