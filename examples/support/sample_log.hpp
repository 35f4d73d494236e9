#pragma once
// Where lesson 01 gets its CARMEN log: the command line, the shared data set, or a five-scan
// sample log written from the text below, so the lesson runs without outside data. Not library
// code: the lesson is how 01_scans.cpp reads and draws the log.

#include <filesystem>
#include <fstream>
#include <iostream>

namespace examples {

/// A corridor 2.4 m wide, closed 8 m ahead, with a doorway on the left and a box on the right
/// floor, seen from five poses 0.5 m apart by a 37-beam scanner over 180 degrees. 81.91 is the
/// SICK scanner's "no return" value (nothing within range, here: the open door).
inline constexpr const char* sample_carmen_log =
    R"(# A small CARMEN log written by rangenav example 01_scans
FLASER 37 1.21 1.22 1.22 1.23 1.27 1.32 1.38 1.45 1.57 1.70 1.87 2.08 2.40 2.43 2.33 4.64 6.91 8.05 8.00 8.03 6.92 4.64 81.91 2.85 2.40 2.09 1.88 1.70 1.57 1.45 1.39 1.32 1.28 1.24 1.23 1.20 1.20 0.000 0.000 0.000 0.000 0.000 0.000 1000.000 sample 1000.010
FLASER 37 1.23 1.22 1.24 1.27 1.33 1.36 1.44 1.53 1.63 1.76 1.98 2.03 1.94 1.84 3.88 5.32 7.59 7.50 7.49 7.55 5.82 4.10 81.91 2.63 2.23 1.98 1.78 1.62 1.49 1.40 1.35 1.27 1.24 1.20 1.19 1.18 1.18 0.500 0.020 0.030 0.500 0.020 0.030 1000.200 sample 1000.210
FLASER 37 1.27 1.27 1.30 1.31 1.35 1.42 1.46 1.58 1.71 1.61 1.51 1.41 1.62 3.32 4.23 5.94 7.05 7.02 7.01 7.07 5.17 3.73 81.91 81.91 2.13 1.86 1.69 1.54 1.43 1.35 1.31 1.25 1.20 1.17 1.15 1.15 1.15 1.000 0.050 0.050 1.000 0.050 0.050 1000.400 sample 1000.410
FLASER 37 1.27 1.25 1.28 1.30 1.34 1.41 1.35 1.19 1.08 1.11 1.20 2.27 2.59 3.12 3.92 5.26 6.57 6.52 6.50 6.54 5.89 4.11 3.17 81.91 81.91 81.91 1.73 1.58 1.47 1.38 1.31 1.25 1.20 1.16 1.15 1.15 1.15 1.500 0.060 0.020 1.500 0.060 0.020 1000.600 sample 1000.610
FLASER 37 1.25 1.25 1.22 0.82 0.81 0.82 0.86 0.89 1.61 1.75 1.92 2.16 2.47 2.90 3.57 4.65 6.09 6.03 6.03 6.02 6.07 4.62 3.47 2.77 2.35 81.91 81.91 81.91 1.51 1.43 1.34 1.28 1.25 1.19 1.16 1.17 1.14 2.000 0.050 -0.010 2.000 0.050 -0.010 1000.800 sample 1000.810
)";

/// The log to read: `argv[1]` if given, else the MIT CSAIL log under `data_dir` when present,
/// else sample_carmen_log written to `out_dir`/sample.clf.
inline std::filesystem::path choose_log(int argc, char** argv,
                                        const std::filesystem::path& data_dir,
                                        const std::filesystem::path& out_dir) {
  if (argc > 1) return argv[1];
  const std::filesystem::path shared = data_dir / "carmen" / "mit-csail.clf.gz";
  if (std::filesystem::exists(shared)) return shared;
  const std::filesystem::path sample = out_dir / "sample.clf";
  std::ofstream(sample) << sample_carmen_log;
  std::cout << "(shared data not found: reading the sample log written to " << sample.string()
            << ")\n";
  return sample;
}

}  // namespace examples
