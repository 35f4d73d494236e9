// libFuzzer harness: CarmenReader over every record of arbitrary bytes, with and without the
// saturation detection. Every pose and timestamp returned must be finite, every scan consistent.
// read_carmen_scan_log over the same bytes: one odometry entry per record, each finite, every
// record of the chosen laser, the other lasers' records counted.
#include <cmath>
#include <cstdlib>
#include <variant>

#include "fuzz_support.hpp"
#include "rangenav/io/carmen.hpp"

namespace {
bool finite(const rangenav::Pose2d& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.theta);
}

void read_all(const std::filesystem::path& path, rangenav::io::CarmenReaderOptions options) {
  using namespace rangenav::io;
  CarmenReader reader(path, options);
  while (auto record = reader.next()) {
    if (const auto* laser = std::get_if<CarmenLaser>(&*record)) {
      if (!std::isfinite(laser->timestamp) || !std::isfinite(laser->logger_timestamp)) std::abort();
      if ((laser->laser_pose && !finite(*laser->laser_pose)) ||
          (laser->odom_pose && !finite(*laser->odom_pose)))
        std::abort();
      const auto& scan = laser->scan;
      if (!(scan.range_max() > scan.range_min())) std::abort();
      for (const auto i : scan.valid_indices())
        if (!(scan.range(i) < scan.range_max())) std::abort();
    } else {
      const auto& odom = std::get<CarmenOdometry>(*record);
      if (!finite(odom.pose) || !std::isfinite(odom.tv) || !std::isfinite(odom.timestamp))
        std::abort();
    }
  }
}

void read_scan_log(const std::filesystem::path& path) {
  using namespace rangenav::io;
  const CarmenScanLog log = read_carmen_scan_log(path);
  if (log.odometry.size() != log.records.size()) std::abort();
  if (static_cast<std::size_t>(log.laser) >= carmen_laser_type_count) std::abort();
  for (std::size_t i = 0; i < log.records.size(); ++i) {
    if (log.records[i].type != log.laser) std::abort();
    if (log.odometry[i] && !finite(*log.odometry[i])) std::abort();
  }
  // Another laser's records are among those counted as left out.
  const auto other = static_cast<CarmenLaserType>((static_cast<std::size_t>(log.laser) + 1) %
                                                  carmen_laser_type_count);
  if (read_carmen_scan_log(path, other).records.size() > log.other_laser_records) std::abort();
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace rangenav;
  const auto& path = fuzz::as_file(data, size);
  fuzz::expect_success_or_error([&] { read_all(path, {}); });
  fuzz::expect_success_or_error(
      [&] { read_all(path, {.detect_saturation = false, .saturation_lookahead = 0}); });
  fuzz::expect_success_or_error([&] { read_scan_log(path); });
  return 0;
}
