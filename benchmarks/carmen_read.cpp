// Time to read the MIT CSAIL benchmark log (1988 FLASER scans of 361 beams, 3.8 MB of text)
// with CarmenReader: from the gzip file as shipped, and from an uncompressed copy (parsing only).

#include <benchmark/benchmark.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "rangenav/io/carmen.hpp"
#include "rangenav/io/line_reader.hpp"

namespace {

const std::filesystem::path gz_log =
    std::filesystem::path(RANGENAV_BENCH_DATA_DIR) / "carmen/mit-csail.clf.gz";

// An uncompressed copy in the temp dir, written once with rangenav's own line reader.
const std::filesystem::path& plain_log() {
  static const std::filesystem::path path = [] {
    const auto out_path = std::filesystem::temp_directory_path() / "rangenav_bench_mit-csail.clf";
    rangenav::io::LineReader lines(gz_log, "bench");
    std::ofstream out(out_path, std::ios::binary);
    std::string_view line;
    while (lines.next(line))
      out << line << '\n';
    return out_path;
  }();
  return path;
}

void read_log(benchmark::State& state, const std::filesystem::path& path) {
  std::size_t beams = 0;
  for (auto _ : state) {
    const auto lasers = rangenav::io::read_carmen_lasers(path);
    beams = 0;
    for (const auto& laser : lasers)
      beams += laser.scan.size();
    benchmark::DoNotOptimize(beams);
  }
  state.counters["beams"] = static_cast<double>(beams);
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) *
                          static_cast<std::int64_t>(std::filesystem::file_size(plain_log())));
}

// Both rows need the gzip log and zlib (the plain copy is unpacked from it); otherwise the row
// is skipped with the reason.
bool log_available(benchmark::State& state) {
#ifndef RANGENAV_HAVE_ZLIB
  state.SkipWithError("built without zlib");
  return false;
#else
  if (std::filesystem::exists(gz_log)) return true;
  state.SkipWithError("data file not found: carmen/mit-csail.clf.gz");
  return false;
#endif
}

void BM_carmen_read_mit_gzip(benchmark::State& state) {
  if (log_available(state)) read_log(state, gz_log);
}

void BM_carmen_read_mit_plain(benchmark::State& state) {
  if (log_available(state)) read_log(state, plain_log());
}

}  // namespace

BENCHMARK(BM_carmen_read_mit_gzip)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_carmen_read_mit_plain)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
