// The cell's static entities from their file: what the observation carries, and bad files named.
#include <gtest/gtest.h>

#include <fstream>

#include "dh/common/config.hpp"
#include "dh/rtde/cell_entities.hpp"

namespace dh::rtde {
namespace {

std::filesystem::path write(const std::string& name, const std::string& yaml) {
  const auto dir = std::filesystem::temp_directory_path() / "dh_cell_entities_test";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / name) << yaml;
  return dir / name;
}

std::string error_of(const std::string& yaml) {
  try {
    load_cell_entities(write("bad.yaml", yaml));
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(CellEntities, AreReadAsTheObservationCarriesThem) {
  const auto e = load_cell_entities(write("cell.yaml", R"(entities:
  - {name: cabinet, kind: cabinet, p: [0.05, -0.3, 0], half_extents: [0.1, 0.15, 0.2], colour: white}
  - {name: cabinet_top_drawer, kind: drawer, p: [-0.06, -0.3, 0.25], q: [0.7071068, 0, 0, 0.7071068],
     half_extents: [0.01, 0.05, 0.01], joint: -0.02, owner: cabinet}
  - {name: plate_region, kind: region, p: [-0.2, 0.22, 0], half_extents: [0.06, 0.06, 0.02], owner: plate,
     relation: on}
)"));
  ASSERT_EQ(e.size(), 3u);
  EXPECT_EQ(e[0].name, "cabinet");
  EXPECT_EQ(e[0].category, "cabinet");
  EXPECT_EQ(e[0].colour, "white");
  EXPECT_EQ(e[0].q, (std::array<double, 4>{1, 0, 0, 0}));
  EXPECT_EQ(e[1].kind, "drawer");
  EXPECT_EQ(e[1].category, "drawer");
  EXPECT_EQ(e[1].owner, "cabinet");
  EXPECT_DOUBLE_EQ(e[1].joint, -0.02);
  EXPECT_DOUBLE_EQ(e[1].q[3], 0.7071068);
  EXPECT_EQ(e[2].kind, "region");
  EXPECT_EQ(e[2].category, "");
  EXPECT_EQ(e[2].relation, "on");
  EXPECT_EQ(e[2].owner, "plate") << "a region's owner may be a free object, which perception names";
}

TEST(CellEntities, BadFilesAreNamedWithTheirKey) {
  EXPECT_NE(error_of("entities:\n  - {name: a, kind: cabinet, p: [0, 0], half_extents: [1, 1, 1]}\n")
                .find("bad.yaml: key 'entities[0].p': expected a list of 3 numbers"),
            std::string::npos)
      << error_of("entities:\n  - {name: a, kind: cabinet, p: [0, 0], half_extents: [1, 1, 1]}\n");
  EXPECT_NE(error_of("entities:\n  - {name: d, kind: drawer, p: [0, 0, 0], half_extents: [1, 1, 1]}\n")
                .find("a drawer needs the entity it belongs to"),
            std::string::npos);
  EXPECT_NE(
      error_of("entities:\n  - {name: d, kind: drawer, p: [0, 0, 0], half_extents: [1, 1, 1], owner: x}\n")
          .find("'x' is not an entity of this file"),
      std::string::npos);
  EXPECT_NE(
      error_of("entities:\n  - {name: r, kind: region, p: [0, 0, 0], half_extents: [1, 1, 1], owner: x}\n")
          .find("a region needs its relation"),
      std::string::npos);
  EXPECT_NE(error_of("entities:\n  - {name: a, kind: box, p: [0, 0, 0], half_extents: [1, 1, 1]}\n"
                     "  - {name: a, kind: box, p: [0, 0, 0], half_extents: [1, 1, 1]}\n")
                .find("'a' is named twice"),
            std::string::npos);
  EXPECT_NE(error_of("cell: {}\n").find("entities"), std::string::npos);
}

}  // namespace
}  // namespace dh::rtde
