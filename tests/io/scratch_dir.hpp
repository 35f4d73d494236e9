#pragma once
// A fresh directory under the system's temporary directory for files a test writes; removed with
// everything in it when the object goes out of scope.

#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <string_view>
#include <system_error>

namespace rangenav::test {

class ScratchDir {
 public:
  explicit ScratchDir(std::string_view tag) {
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() /
            ("rangenav_" + std::string(tag) + "_" + std::to_string(rd()) + std::to_string(rd()));
    std::filesystem::create_directories(path_);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }

  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  [[nodiscard]] std::filesystem::path operator/(std::string_view name) const {
    return path_ / name;
  }
  /// Writes `content` to the file `name` in this directory and returns its path.
  std::filesystem::path write(std::string_view name, const std::string& content) const {
    const auto file = path_ / name;
    std::ofstream(file, std::ios::binary) << content;
    return file;
  }

 private:
  std::filesystem::path path_;
};

}  // namespace rangenav::test
