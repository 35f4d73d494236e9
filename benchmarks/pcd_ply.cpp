// Time to read and write real clouds with rangenav's PCD / PLY I/O, and with PCL 1.13's when it
// is installed (RANGENAV_HAVE_PCL): the organised 640 x 480 binary_compressed table scene, MRPT's
// organised 160 x 120 ascii frame and small_gicp's binary PLY scan (69,792 vertices). At the end
// the program prints PCL's time over rangenav's for each pair run.

#include <benchmark/benchmark.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "rangenav/io/pcd.hpp"
#include "rangenav/io/ply.hpp"
#include "ratio_runs.hpp"

#ifdef RANGENAV_HAVE_PCL
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>
#endif

namespace {

const std::filesystem::path data_dir(RANGENAV_BENCH_DATA_DIR);
const std::filesystem::path table = data_dir / "pcl_test/table_scene_mug_stereo_textured.pcd";
const std::filesystem::path frame = data_dir / "mrpt_pbmap/pointcloud0.pcd";
const std::filesystem::path scan = data_dir / "small_gicp/source.ply";

std::filesystem::path scratch(const char* name) {
  return std::filesystem::temp_directory_path() / (std::string("rangenav_bench_") + name);
}

bool have(benchmark::State& state, const std::filesystem::path& path) {
  if (std::filesystem::exists(path)) return true;
  state.SkipWithError(("data file not found: " + path.string()).c_str());
  return false;
}

void count_points(benchmark::State& state, std::size_t n, const std::filesystem::path& path) {
  state.counters["points"] = static_cast<double>(n);
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) *
                          static_cast<std::int64_t>(std::filesystem::file_size(path)));
}

void BM_rangenav_read_pcd(benchmark::State& state, const std::filesystem::path& path) {
  if (!have(state, path)) return;
  std::size_t n = 0;
  for (auto _ : state) {
    const auto cloud = rangenav::io::read_pcd<float>(path);
    n = cloud.size();
    benchmark::DoNotOptimize(cloud.points.data());
  }
  count_points(state, n, path);
}

void BM_rangenav_read_ply(benchmark::State& state, const std::filesystem::path& path) {
  if (!have(state, path)) return;
  std::size_t n = 0;
  for (auto _ : state) {
    const auto cloud = rangenav::io::read_ply<float>(path);
    n = cloud.size();
    benchmark::DoNotOptimize(cloud.points.data());
  }
  count_points(state, n, path);
}

void BM_rangenav_write_pcd(benchmark::State& state, rangenav::io::PcdFormat format) {
  if (!have(state, table)) return;
  const auto cloud = rangenav::io::read_pcd<float>(table);
  const auto out = scratch("write.pcd");
  for (auto _ : state)
    rangenav::io::write_pcd(out, cloud, format);
  count_points(state, cloud.size(), out);
  std::filesystem::remove(out);
}

#ifdef RANGENAV_HAVE_PCL
template <class PointT>
void BM_pcl_read_pcd(benchmark::State& state, const std::filesystem::path& path) {
  if (!have(state, path)) return;
  std::size_t n = 0;
  for (auto _ : state) {
    pcl::PointCloud<PointT> cloud;
    if (pcl::io::loadPCDFile(path.string(), cloud) < 0) state.SkipWithError("PCL failed");
    n = cloud.size();
    benchmark::DoNotOptimize(cloud.points.data());
  }
  count_points(state, n, path);
}

void BM_pcl_read_ply(benchmark::State& state, const std::filesystem::path& path) {
  if (!have(state, path)) return;
  std::size_t n = 0;
  for (auto _ : state) {
    pcl::PointCloud<pcl::PointXYZ> cloud;
    if (pcl::io::loadPLYFile(path.string(), cloud) < 0) state.SkipWithError("PCL failed");
    n = cloud.size();
    benchmark::DoNotOptimize(cloud.points.data());
  }
  count_points(state, n, path);
}

void BM_pcl_write_pcd(benchmark::State& state, rangenav::io::PcdFormat format) {
  if (!have(state, table)) return;
  pcl::PointCloud<pcl::PointXYZRGBA> cloud;
  pcl::io::loadPCDFile(table.string(), cloud);
  const auto out = scratch("write_pcl.pcd");
  pcl::PCDWriter writer;
  for (auto _ : state) {
    if (format == rangenav::io::PcdFormat::binary)
      writer.writeBinary(out.string(), cloud);
    else
      writer.writeBinaryCompressed(out.string(), cloud);
  }
  count_points(state, cloud.size(), out);
  std::filesystem::remove(out);
}
#endif

/// Console output as usual, and the CPU times (medians when repeated) kept to print the PCL /
/// rangenav ratios.
class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const auto& r : runs)
      if (rangenav_bench::is_ratio_run(r)) cpu_[r.run_name.str()] = r.GetAdjustedCPUTime();
    ConsoleReporter::ReportRuns(runs);
  }
  void print_ratios() const {
    for (const auto& [name, ours] : cpu_) {
      if (name.rfind("rangenav_", 0) != 0) continue;
      const auto peer = cpu_.find("pcl_" + name.substr(9));
      if (peer != cpu_.end())
        std::printf("%-32s PCL / rangenav CPU time = %.2f\n", name.substr(9).c_str(),
                    peer->second / ours);
    }
  }

 private:
  std::map<std::string, double> cpu_;
};

}  // namespace

int main(int argc, char** argv) {
  using rangenav::io::PcdFormat;
  const auto ms = benchmark::kMillisecond;
  benchmark::RegisterBenchmark("rangenav_read_pcd/table_binary_compressed", BM_rangenav_read_pcd,
                               table)
      ->Unit(ms);
  benchmark::RegisterBenchmark("rangenav_read_pcd/frame_ascii", BM_rangenav_read_pcd, frame)
      ->Unit(ms);
  benchmark::RegisterBenchmark("rangenav_read_ply/scan_binary", BM_rangenav_read_ply, scan)
      ->Unit(ms);
  benchmark::RegisterBenchmark("rangenav_write_pcd/table_binary", BM_rangenav_write_pcd,
                               PcdFormat::binary)
      ->Unit(ms);
  benchmark::RegisterBenchmark("rangenav_write_pcd/table_binary_compressed", BM_rangenav_write_pcd,
                               PcdFormat::binary_compressed)
      ->Unit(ms);
#ifdef RANGENAV_HAVE_PCL
  benchmark::RegisterBenchmark("pcl_read_pcd/table_binary_compressed",
                               BM_pcl_read_pcd<pcl::PointXYZRGBA>, table)
      ->Unit(ms);
  benchmark::RegisterBenchmark("pcl_read_pcd/frame_ascii", BM_pcl_read_pcd<pcl::PointXYZRGBA>,
                               frame)
      ->Unit(ms);
  benchmark::RegisterBenchmark("pcl_read_ply/scan_binary", BM_pcl_read_ply, scan)->Unit(ms);
  benchmark::RegisterBenchmark("pcl_write_pcd/table_binary", BM_pcl_write_pcd, PcdFormat::binary)
      ->Unit(ms);
  benchmark::RegisterBenchmark("pcl_write_pcd/table_binary_compressed", BM_pcl_write_pcd,
                               PcdFormat::binary_compressed)
      ->Unit(ms);
#endif
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  RatioReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  reporter.print_ratios();
  benchmark::Shutdown();
  return 0;
}
