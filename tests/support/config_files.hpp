// For tests of configuration errors: a temporary folder of files written by the test, and the message of
// the ConfigError a call throws.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include "dh/common/config.hpp"

namespace dh::test {

/// The message of the ConfigError `f` throws; "" when it throws none.
inline std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

/// A folder named after the running test, removed with everything in it when this goes.
struct TempDir {
  std::filesystem::path dir =
      std::filesystem::temp_directory_path() /
      ("dh_cfg_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
  TempDir() { std::filesystem::create_directories(dir); }
  ~TempDir() { std::filesystem::remove_all(dir); }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  /// Writes `text` to `name` below the folder (its folders made) and returns the file's path.
  std::filesystem::path write(const std::string& name, const std::string& text) const {
    std::filesystem::create_directories((dir / name).parent_path());
    std::ofstream(dir / name) << text;
    return dir / name;
  }
};

}  // namespace dh::test
