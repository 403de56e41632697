// `dh library perturb`: every θ drawn within its range (whole step counts), the same seed the same draw,
// the files otherwise kept, a folder with files refused.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "dh/cap/library_theta.hpp"
#include "dh/common/paths.hpp"
#include "dh/evo/perturb.hpp"

using namespace dh;
namespace fs = std::filesystem;

namespace {
fs::path temp(const std::string& name) {
  const fs::path p = fs::path(::testing::TempDir()) / ("dh_perturb_" + std::to_string(getpid()) + "_" + name);
  fs::remove_all(p);
  return p;
}
std::string read_text(const fs::path& f) {
  std::ifstream in(f);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}
}  // namespace

TEST(LibraryPerturb, DrawsEveryThetaWithinItsRangeTheSameForTheSameSeed) {
  const fs::path shipped = paths::config_dir() / "library";
  const cap::LibraryTheta lib = cap::load_library_theta(shipped);
  const fs::path dir_a = temp("a"), dir_b = temp("b");
  const auto a = evo::perturb_library(shipped, 1, dir_a);
  const auto again = evo::perturb_library(shipped, 1, temp("again"));
  const auto b = evo::perturb_library(shipped, 2, dir_b);
  EXPECT_EQ(a.theta, again.theta);
  EXPECT_EQ(a.version, again.version);
  EXPECT_NE(a.theta, b.theta);
  EXPECT_NE(a.version, lib.version);
  std::size_t parameters = 0, moved = 0;
  for (const auto& [capability, theta] : lib.theta) {
    ASSERT_TRUE(a.theta.count(capability)) << capability;
    for (const auto& [name, shipped_value] : theta) {
      const double v = a.theta.at(capability).at(name);
      const cap::ParameterRange& r = lib.ranges.at(capability).at(name);
      EXPECT_GE(v, r.min) << capability << "." << name;
      EXPECT_LE(v, r.max) << capability << "." << name;
      if (r.unit == "steps") {
        EXPECT_EQ(v, std::round(v)) << capability << "." << name << " is a step count";
      }
      ++parameters;
      moved += v != shipped_value;
    }
  }
  EXPECT_GT(parameters, 50u);
  EXPECT_GT(moved, parameters * 3 / 4) << "a draw, not the shipped values";
  // The written files load with exactly the drawn θ, keep their ranges and comments, and say how they were
  // made.
  EXPECT_EQ(cap::load_library_theta(dir_a).theta, a.theta);
  const std::string text = read_text(dir_b / "pick_place.yaml");
  EXPECT_NE(text.find("dh library perturb --seed 2"), std::string::npos);
  EXPECT_NE(text.find("# m above the grasp point before the guarded descent"), std::string::npos)
      << "comments kept";
  EXPECT_NE(text.find("ranges:"), std::string::npos);
  for (const char* d : {"a", "b", "again"}) fs::remove_all(temp(d));
}

TEST(LibraryPerturb, AFolderWithFilesIsRefused) {
  const fs::path out = temp("full");
  fs::create_directories(out);
  std::ofstream(out / "keep.yaml") << "mine: 1\n";
  try {
    evo::perturb_library(paths::config_dir() / "library", 1, out);
    ADD_FAILURE() << "wrote into a folder with files";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(out.string()), std::string::npos) << e.what();
  }
  EXPECT_EQ(read_text(out / "keep.yaml"), "mine: 1\n");
  fs::remove_all(out);
}
