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

// What the test controller writes for the adapter is read back as it was written.
TEST(CellEntities, WrittenAreReadBackAsTheyWere) {
  EntityState cabinet{"cabinet", "cabinet", {0.05, -0.3, 0}, {1, 0, 0, 0}, {0.1, 0.15, 0.2}, 0, "cabinet", "white",
                      "", ""};
  EntityState drawer{"cabinet_top_drawer", "drawer", {-0.0612345678, -0.3, 0.25}, {0.7071067812, 0, 0, 0.7071067812},
                     {0.005, 0.035, 0.006}, 0.0421, "drawer", "", "cabinet", ""};
  EntityState region{"plate_region", "region", {-0.2, 0.22, 0}, {1, 0, 0, 0}, {0.06, 0.06, 0.02}, 0, "", "", "plate",
                     "on"};
  const std::vector<EntityState> written{cabinet, drawer, region};
  const auto file = write("round_trip.yaml", cell_entities_yaml(written, ArmBase{-0.56, 0.01, 0, 0.25}));
  EXPECT_EQ(load_cell_base(file), (ArmBase{-0.56, 0.01, 0, 0.25}));
  EXPECT_FALSE(load_cell_base(write("no_base.yaml", cell_entities_yaml(written)))) << "the base is optional";
  const auto read = load_cell_entities(file);
  ASSERT_EQ(read.size(), written.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    SCOPED_TRACE(written[i].name);
    EXPECT_EQ(read[i].name, written[i].name);
    EXPECT_EQ(read[i].kind, written[i].kind);
    EXPECT_EQ(read[i].category, written[i].category);
    EXPECT_EQ(read[i].colour, written[i].colour);
    EXPECT_EQ(read[i].owner, written[i].owner);
    EXPECT_EQ(read[i].relation, written[i].relation);
    EXPECT_DOUBLE_EQ(read[i].joint, written[i].joint);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(read[i].p[k], written[i].p[k], 1e-10);
      EXPECT_NEAR(read[i].half_extents[k], written[i].half_extents[k], 1e-10);
    }
    for (int k = 0; k < 4; ++k) EXPECT_NEAR(read[i].q[k], written[i].q[k], 1e-10);
  }
}

TEST(CellEntities, BadFilesAreNamedWithTheirKey) {
  try {
    load_cell_base(write("bad.yaml", "base: [-0.56, 0, 0]\nentities: []\n"));
    ADD_FAILURE() << "a base of 3 numbers was read";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.yaml: key 'base': expected a list of 4 numbers"), std::string::npos) << e.what();
  }
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
