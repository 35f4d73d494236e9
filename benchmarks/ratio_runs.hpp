#pragma once
// What the benchmarks that print a ratio table share: which of google-benchmark's runs carry the
// time to compare.

#include <benchmark/benchmark.h>

namespace rangenav_bench {

/// Whether a ratio table takes its times from `run`: a single run, or the median of repeated
/// ones (--benchmark_repetitions; --benchmark_report_aggregates_only reports only those).
inline bool is_ratio_run(const benchmark::BenchmarkReporter::Run& run) {
  using Run = benchmark::BenchmarkReporter::Run;
  if (run.error_occurred) return false;
  return (run.run_type == Run::RT_Iteration && run.repetitions <= 1) ||
         (run.run_type == Run::RT_Aggregate && run.aggregate_name == "median");
}

}  // namespace rangenav_bench
