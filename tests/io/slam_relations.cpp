#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "rangenav/io/slam_relations.hpp"
#include "test_support.hpp"

using namespace rangenav;
using namespace rangenav::io;

namespace {

/// A file under the system temp dir, removed at scope exit.
class TempFile {
 public:
  explicit TempFile(const std::string& content) {
    std::random_device random;
    path_ = std::filesystem::temp_directory_path() /
            ("rangenav_relations_" + std::to_string(random()) + std::to_string(random()));
    std::ofstream(path_, std::ios::binary) << content;
  }
  ~TempFile() {
    std::error_code ignored;
    std::filesystem::remove(path_, ignored);
  }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace

TEST_CASE("read_slam_relations parses the benchmark format", "[io][relations]") {
  // Two spaces between fields 5 and 6, as in mit-csail.relations; a comment and a blank line.
  const TempFile file(
      "# comment\n"
      "976052905.167303 976052911.885496 -0.056990 -0.128430 0.000000  0.000000 0.000000 "
      "-1.682210\n"
      "\n"
      "10.5 11.0 1.0 2.0 0 0 0 4.0\n");
  const auto relations = read_slam_relations(file.path());
  REQUIRE(relations.size() == 2);
  CHECK(relations[0].first == 976052905.167303);
  CHECK(relations[0].second == 976052911.885496);
  CHECK(relations[0].delta.x == -0.056990);
  CHECK(relations[0].delta.y == -0.128430);
  CHECK(relations[0].delta.theta == -1.682210);
  CHECK(relations[1].delta.theta == Approx(4.0 - 2 * std::numbers::pi));  // normalised
}

TEST_CASE("read_slam_relations names the file and line of bad input", "[io][relations]") {
  const TempFile short_line("1 2 3 4 5 6 7 8\n1 2 3 4 5 6 7\n");
  CHECK_THROWS_AS(read_slam_relations(short_line.path()), io_error);
  CHECK_THROWS_WITH(
      read_slam_relations(short_line.path()),
      "rangenav: slam_relations: " + short_line.path().string() + ":2: expected 8 fields, found 7");
  const TempFile bad_number("1 2 3 x 5 6 7 8\n");
  CHECK_THROWS_WITH(read_slam_relations(bad_number.path()),
                    "rangenav: slam_relations: " + bad_number.path().string() +
                        ":1: field 4 is not a finite number: 'x'");
  const TempFile truncated("1 2 3 4 5 6 7 8\n1 2 3");
  CHECK_THROWS_WITH(read_slam_relations(truncated.path()),
                    "rangenav: slam_relations: " + truncated.path().string() +
                        ":2: expected 8 fields, found 3 (unterminated last line: truncated "
                        "file?)");
  CHECK_THROWS_AS(read_slam_relations("/nonexistent/dir/x.relations"), io_error);
  const TempFile empty("");
  CHECK(read_slam_relations(empty.path()).empty());
}

TEST_CASE("evaluate_slam_relations computes the Kümmerle metric", "[io][relations]") {
  // A true trajectory and the relations it implies.
  const std::vector<double> stamps{0.0, 0.5, 1.0, 10.0};
  const std::vector<Pose2d> truth{
      {0.0, 0.0, 0.0}, {1.0, 0.0, 0.5}, {1.5, 1.0, 1.0}, {-2.0, 3.0, -2.5}};
  std::vector<SlamRelation> relations;
  for (std::size_t i = 0; i < 3; ++i)
    relations.push_back({stamps[i], stamps[i + 1], relative(truth[i], truth[i + 1])});
  relations.push_back({stamps[0], stamps[2], relative(truth[0], truth[2])});

  SECTION("the true trajectory, moved rigidly, has no error") {
    std::vector<Pose2d> moved;
    for (const auto& p : truth)
      moved.push_back(compose(Pose2d{5.0, -3.0, 2.0}, p));
    const auto e = evaluate_slam_relations(relations, stamps, moved);
    CHECK(e.all.count == 4);
    CHECK(e.missing == 0);
    CHECK(e.all.translation_mean == Approx(0.0).margin(1e-12));
    CHECK(e.all.rotation_mean == Approx(0.0).margin(1e-12));
    CHECK(e.short_gap.count == 3);  // 0.5 s and 1 s apart
    CHECK(e.long_gap.count == 1);   // 9 s apart
  }
  SECTION("a known error in the last pose") {
    auto estimate = truth;
    estimate[3] = compose(truth[3], Pose2d{0.3, -0.4, 0.1});  // 0.5 m and 0.1 rad off
    const auto e = evaluate_slam_relations(relations, stamps, estimate);
    REQUIRE(e.long_gap.count == 1);
    CHECK(e.long_gap.translation_mean == Approx(0.5));
    CHECK(e.long_gap.rotation_mean == Approx(0.1));
    CHECK(e.short_gap.translation_mean == Approx(0.0).margin(1e-12));
    CHECK(e.all.translation_mean == Approx(0.5 / 4));
    CHECK(e.all.translation_stddev == Approx(std::sqrt(0.25 / 4 - 0.125 * 0.125)));
  }
  SECTION("timestamps are matched within the tolerance, else counted as missing") {
    const std::vector<double> jittered{0.0004, 0.4996, 1.0, 10.01};
    const auto e = evaluate_slam_relations(relations, jittered, truth);
    CHECK(e.all.count == 3);
    CHECK(e.missing == 1);
    CHECK(e.all.translation_mean == Approx(0.0).margin(1e-12));
  }
  SECTION("bad input") {
    CHECK_THROWS_WITH(evaluate_slam_relations(relations, stamps, std::vector<Pose2d>(3)),
                      "rangenav: evaluate_slam_relations: argument 'poses.size()' = 3 must equal "
                      "timestamps.size() = 4");
    const std::vector<double> unordered{0.0, 1.0, 1.0, 2.0};
    CHECK_THROWS_WITH(evaluate_slam_relations(relations, unordered, truth),
                      "rangenav: evaluate_slam_relations: argument 'timestamps[2]' = 1 must "
                      "exceed the one before");
    const auto e = evaluate_slam_relations(relations, {}, {});
    CHECK(e.missing == 4);
    CHECK(e.all.count == 0);
  }
}

TEST_CASE("nearest_timestamp matches a time to the nearest entry within the offset",
          "[io][relations]") {
  // Binary fractions: the gaps are exact, so the tie below is one.
  const std::vector<double> stamps{10.0, 10.25, 10.5, 11.0};
  CHECK(nearest_timestamp(stamps, 10.25) == 1u);       // exact
  CHECK(nearest_timestamp(stamps, 10.2505) == 1u);     // within the default 1 ms
  CHECK_FALSE(nearest_timestamp(stamps, 10.252));      // 2 ms from the nearest
  CHECK(nearest_timestamp(stamps, 10.3, 0.1) == 1u);   // nearer the one before
  CHECK(nearest_timestamp(stamps, 10.45, 0.1) == 2u);  // nearer the one after
  CHECK(nearest_timestamp(stamps, 10.75, 0.3) == 3u);  // a tie: the later one
  CHECK(nearest_timestamp(stamps, 9.9995) == 0u);      // before the first
  CHECK(nearest_timestamp(stamps, 11.0008) == 3u);     // after the last
  CHECK_FALSE(nearest_timestamp(stamps, 12.0, 0.5));   // beyond the last by more
  CHECK_FALSE(nearest_timestamp(std::vector<double>{}, 1.0, 10.0));
}

TEST_CASE("the MIT CSAIL relations match the CARMEN log's timestamps", "[io][relations][data]") {
  const auto path = rangenav::test::data_file_or_skip("slam-benchmark/mit-csail.relations");
  if (path.empty()) return;
  const auto relations = read_slam_relations(path);
  REQUIRE(relations.size() == 1172);
  std::size_t short_gap = 0;
  for (const auto& r : relations)
    if (std::abs(r.second - r.first) < 2.0) ++short_gap;
  CHECK(short_gap == 1044);  // as the data README says
}
