// The registry: append-only with a chain of hashes (an edited or removed line is found, the last one
// too), a rejected
// candidate leaves the current library, an admitted one becomes a read-only, content-addressed snapshot.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "dh/common/paths.hpp"
#include "dh/evo/registry.hpp"

using namespace dh;
namespace fs = std::filesystem;

namespace {
struct RegistryTest : ::testing::Test {
  fs::path dir = fs::path(::testing::TempDir()) / ("dh_registry_" + std::to_string(getpid()));
  void SetUp() override { fs::remove_all(dir); }
  void TearDown() override {
    for (const auto& e : fs::recursive_directory_iterator(dir, fs::directory_options::skip_permission_denied))
      if (e.is_regular_file()) fs::permissions(e.path(), fs::perms::owner_all);
    fs::remove_all(dir);
  }
  std::vector<std::string> lines() const {
    std::ifstream in(dir / "reg" / "registry.jsonl");
    std::vector<std::string> v;
    for (std::string l; std::getline(in, l);) v.push_back(l);
    return v;
  }
  void write(const std::vector<std::string>& v) const {
    std::ofstream out(dir / "reg" / "registry.jsonl", std::ios::trunc);
    for (const auto& l : v) out << l << "\n";
  }
};
}  // namespace

TEST_F(RegistryTest, RejectedLeavesTheCurrentLibraryAdmittedBecomesAFrozenSnapshot) {
  evo::Registry reg(dir / "reg");
  EXPECT_TRUE(reg.entries().empty());
  EXPECT_FALSE(reg.current());
  const auto library = paths::config_dir() / "library";
  const auto r1 =
      reg.append({{"capability", "pick_place"}, {"candidate_version", "lib-aaaa"}, {"reason", "gate failed"}},
                 library, false);
  EXPECT_EQ(r1["id"], "r1");
  EXPECT_EQ(r1["decision"], "rejected");
  EXPECT_FALSE(r1.contains("snapshot"));
  EXPECT_FALSE(reg.current()) << "a rejected candidate is not the current library";
  const auto r2 =
      reg.append({{"capability", "pick_place"}, {"candidate_version", "lib-bbbb"}}, library, true);
  EXPECT_EQ(r2["id"], "r2");
  ASSERT_TRUE(reg.current());
  EXPECT_EQ(*reg.current(), reg.snapshot("lib-bbbb"));
  EXPECT_TRUE(fs::exists(reg.snapshot("lib-bbbb") / "pick_place.yaml"));
  const auto perms = fs::status(reg.snapshot("lib-bbbb") / "pick_place.yaml").permissions();
  EXPECT_EQ(perms & fs::perms::owner_write, fs::perms::none) << "frozen";
  ASSERT_EQ(reg.entries().size(), 2u);
  EXPECT_EQ(reg.find("r1")->at("reason"), "gate failed");
  EXPECT_FALSE(reg.find("r3"));
}

TEST_F(RegistryTest, AnEditedOrRemovedLineBreaksTheChain) {
  evo::Registry reg(dir / "reg");
  const auto library = paths::config_dir() / "library";
  reg.append({{"candidate_version", "lib-aaaa"}}, library, false);
  reg.append({{"candidate_version", "lib-bbbb"}}, library, false);
  reg.append({{"candidate_version", "lib-cccc"}}, library, false);
  const auto original = lines();
  ASSERT_EQ(original.size(), 3u);

  auto edited = original;
  const auto at = edited[0].find("rejected");
  edited[0].replace(at, 8, "admitted");  // a rejection rewritten as an admission
  write(edited);
  try {
    reg.entries();
    ADD_FAILURE() << "an edited line went unnoticed";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("line 2"), std::string::npos) << e.what();
  }
  write({original[0], original[2]});  // a line removed
  EXPECT_THROW(reg.entries(), std::runtime_error);
  EXPECT_THROW(reg.append({{"candidate_version", "lib-dddd"}}, library, false), std::runtime_error)
      << "nothing is appended to a broken registry";
  auto last_edited = original;
  last_edited[2].replace(last_edited[2].find("rejected"), 8,
                         "admitted");  // the last line, which no line follows
  write(last_edited);
  EXPECT_THROW(reg.entries(), std::runtime_error);
  write({original[0], original[1]});  // the last line removed
  EXPECT_THROW(reg.entries(), std::runtime_error);
  write(original);
  EXPECT_EQ(reg.entries().size(), 3u);
}
