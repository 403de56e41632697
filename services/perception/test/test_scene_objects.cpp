// What the perception service looks for in a workcell (free objects, their colours and sizes from the
// scene description) and how it picks, among a colour's candidates, the one of the object's shape.
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/perception/scene_entities.hpp"
#include "synthetic_scene.hpp"

namespace dh::perception {
namespace {

using synth::Box;

Mask mask_of(const synth::Rendered& r, int id, const std::string& entity) {
  return {entity, synth::id_mask(r, id), 1.0};
}

LookFor object(const std::string& name, const Eigen::Vector3d& size) {
  LookFor o;
  o.appearance = {name, {{200, 40, 40}}, 40, 0};
  o.size = size;
  return o;
}

TEST(SceneObjects, TheGoalKitchensFreeObjectsWithTheirColoursAndSizes) {
  const auto suites = load_suites(paths::config_dir());
  const auto objects = free_objects(sim::load_nominal_scene(find_task(suites, "goal", 8)));
  std::vector<std::string> names;
  for (const auto& o : objects) names.push_back(o.appearance.entity);
  for (const char* fixture : {"cabinet", "stove", "wine_rack"})
    EXPECT_EQ(std::find(names.begin(), names.end(), fixture), names.end()) << fixture << " is the cell's layout";
  const auto bowl = std::find_if(objects.begin(), objects.end(), [](const auto& o) { return o.appearance.entity == "bowl"; });
  ASSERT_NE(bowl, objects.end());
  // configs/assets/bowl.yaml: a wall ring of outer radius 0.0535 m reaching 0.05 m up; colour 0.1 grey.
  EXPECT_NEAR(bowl->size.x(), 0.107, 1e-9);
  EXPECT_NEAR(bowl->size.y(), 0.107, 1e-9);
  EXPECT_NEAR(bowl->size.z(), 0.05, 1e-9);
  EXPECT_EQ(bowl->appearance.rgb.front(), cv::Vec3b(26, 26, 26));
  EXPECT_GT(bowl->appearance.max_area_px, 1000);
}

TEST(SceneObjects, TheCandidateOfTheObjectsShapeWinsAndNothingOfItsShapeIsNotSeen) {
  synth::Scene s;
  s.world_from_camera = synth::workcell_camera();
  // Same colour: a robot link hovering 0.3 m up, and the object on the table.
  s.boxes = {Box{Eigen::Vector3d(-0.1, 0.1, 0.35), 0, Eigen::Vector3d(0.25, 0.08, 0.1), {200, 40, 40}},
             Box{Eigen::Vector3d(0.05, 0.0, 0.025), 0.3, Eigen::Vector3d(0.07, 0.05, 0.05), {200, 40, 40}}};
  const auto r = synth::render(s);
  CloudParams p;
  p.support_z = 0;
  const std::vector<Mask> candidates{mask_of(r, 1, "cube"), mask_of(r, 2, "cube"), mask_of(r, 1, "slab"),
                                     mask_of(r, 2, "slab")};
  const auto est = estimate_objects(r.frame, candidates,
                                    {object("cube", {0.07, 0.05, 0.05}), object("slab", {0.3, 0.3, 0.01})}, p);
  ASSERT_EQ(est.size(), 2u);
  EXPECT_GT(est[0].confidence, 0.5);
  EXPECT_LT((est[0].centroid - Eigen::Vector3d(0.05, 0.0, 0.025)).norm(), 0.004) << est[0].centroid.transpose();
  EXPECT_EQ(est[1].entity, "slab");
  EXPECT_EQ(est[1].confidence, 0) << "neither candidate has a slab's shape: not seen rather than wrong";
}

TEST(SceneObjects, IdenticalObjectsNeverShareACandidate) {
  synth::Scene s;
  s.world_from_camera = synth::workcell_camera();
  s.boxes = {Box{Eigen::Vector3d(-0.08, 0.0, 0.03), 0, Eigen::Vector3d(0.06, 0.06, 0.06), {40, 40, 200}},
             Box{Eigen::Vector3d(0.08, 0.02, 0.03), 0, Eigen::Vector3d(0.06, 0.06, 0.06), {40, 40, 200}}};
  const auto r = synth::render(s);
  CloudParams p;
  p.support_z = 0;
  const std::vector<Mask> candidates{mask_of(r, 1, "pot_1"), mask_of(r, 2, "pot_1"), mask_of(r, 1, "pot_2"),
                                     mask_of(r, 2, "pot_2")};
  const auto est = estimate_objects(r.frame, candidates,
                                    {object("pot_1", {0.06, 0.06, 0.06}), object("pot_2", {0.06, 0.06, 0.06})}, p);
  ASSERT_EQ(est.size(), 2u);
  ASSERT_GT(est[0].confidence, 0);
  ASSERT_GT(est[1].confidence, 0);
  EXPECT_GT((est[0].centroid - est[1].centroid).norm(), 0.1) << "each pot has a box of its own";
}

TEST(SceneObjects, IdenticalObjectsAreToldApartByWhereTheyAreExpected) {
  synth::Scene s;
  s.world_from_camera = synth::workcell_camera();
  const Eigen::Vector3d left(-0.08, 0.0, 0.03), right(0.08, 0.02, 0.03);
  s.boxes = {Box{left, 0, Eigen::Vector3d(0.06, 0.06, 0.06), {40, 40, 200}},
             Box{right, 0, Eigen::Vector3d(0.06, 0.06, 0.06), {40, 40, 200}}};
  const auto r = synth::render(s);
  CloudParams p;
  p.support_z = 0;
  const std::vector<Mask> candidates{mask_of(r, 1, "pot_1"), mask_of(r, 2, "pot_1"), mask_of(r, 1, "pot_2"),
                                     mask_of(r, 2, "pot_2")};
  // pot_1 chooses first by shape alone, so one of the two expectations needs the priors.
  for (const bool pot_1_right : {true, false}) {
    LookFor pot_1 = object("pot_1", {0.06, 0.06, 0.06}), pot_2 = object("pot_2", {0.06, 0.06, 0.06});
    const Eigen::Vector2d off(0.02, 0.03);  // priors a few centimetres off
    pot_1.prior_xy = (pot_1_right ? right : left).head<2>() + off;
    pot_2.prior_xy = (pot_1_right ? left : right).head<2>() - off;
    const auto est = estimate_objects(r.frame, candidates, {pot_1, pot_2}, p);
    ASSERT_EQ(est.size(), 2u);
    EXPECT_EQ(est[0].entity, "pot_1");
    EXPECT_EQ(est[1].entity, "pot_2");
    EXPECT_LT((est[0].centroid - (pot_1_right ? right : left)).norm(), 0.01) << pot_1_right;
    EXPECT_LT((est[1].centroid - (pot_1_right ? left : right)).norm(), 0.01) << pot_1_right;
  }
}

TEST(SceneObjects, OneOfTwoIdenticalObjectsSeenGoesToTheOneExpectedThere) {
  synth::Scene s;
  s.world_from_camera = synth::workcell_camera();
  const Eigen::Vector3d right(0.08, 0.02, 0.03);
  s.boxes = {Box{right, 0, Eigen::Vector3d(0.06, 0.06, 0.06), {40, 40, 200}}};  // the left one is hidden
  const auto r = synth::render(s);
  CloudParams p;
  p.support_z = 0;
  LookFor pot_1 = object("pot_1", {0.06, 0.06, 0.06}), pot_2 = object("pot_2", {0.06, 0.06, 0.06});
  pot_1.prior_xy = Eigen::Vector2d(-0.08, 0.0);
  pot_2.prior_xy = Eigen::Vector2d(0.07, 0.03);
  const auto est = estimate_objects(r.frame, {mask_of(r, 1, "pot_1"), mask_of(r, 1, "pot_2")}, {pot_1, pot_2}, p);
  ASSERT_EQ(est.size(), 2u);
  EXPECT_EQ(est[0].entity, "pot_1");
  EXPECT_EQ(est[0].confidence, 0) << "pot_1 is expected where nothing is seen";
  EXPECT_EQ(est[1].entity, "pot_2");
  ASSERT_GT(est[1].confidence, 0);
  EXPECT_LT((est[1].centroid - right).norm(), 0.01);
}

TEST(SceneObjects, AKnownTableKeepsAThinObjectThatASearchedPlaneWouldTakeForTheSupport) {
  synth::Scene s;
  s.world_from_camera = synth::workcell_camera();
  s.boxes = {Box{Eigen::Vector3d(0.0, 0.0, 0.006), 0, Eigen::Vector3d(0.18, 0.18, 0.012), {230, 230, 230}}};
  const auto r = synth::render(s);
  CloudParams known;
  known.support_z = 0;
  const EntityEstimate e = estimate_entity(r.frame, mask_of(r, 1, "plate"), known);
  EXPECT_GT(e.confidence, 0.5);
  EXPECT_LT((e.centroid - Eigen::Vector3d(0, 0, 0.006)).norm(), 0.003) << e.centroid.transpose();
  EXPECT_NEAR(e.size.z(), 0.012, 0.003) << "the box reaches down to the known table";
}

TEST(SceneObjects, AnObjectWhoseColourMatchesOnlyItsTopIsSeenByGrowingOverDepthOnAKnownTable) {
  synth::Scene s;
  s.world_from_camera = synth::workcell_camera();
  s.cylinders = {synth::Cylinder{Eigen::Vector3d(0.02, 0.03, 0.0), 0.038, 0.16, {150, 150, 155}}};
  const auto r = synth::render(s);
  // The candidate is the top cap only: what colour finds of a grey pot lit from above.
  const cv::Mat1b top = synth::id_mask_above(r, 1, 0.158);
  const std::vector<Mask> candidates{{"moka_pot", top, 1.0}};
  const std::vector<LookFor> pot{object("moka_pot", {0.076, 0.076, 0.16})};
  CloudParams searched;
  EXPECT_EQ(estimate_objects(r.frame, candidates, pot, searched)[0].confidence, 0) << "a flat top is no pot";
  CloudParams known;
  known.support_z = 0;
  const EntityEstimate e = estimate_objects(r.frame, candidates, pot, known)[0];
  ASSERT_GT(e.confidence, 0);
  EXPECT_LT((e.centroid - Eigen::Vector3d(0.02, 0.03, 0.08)).norm(), 0.01) << e.centroid.transpose();
  EXPECT_NEAR(e.size.z(), 0.16, 0.01);
}

/// A butter-sized yellow box centred at `at` on the table, seen by the workcell camera.
synth::Rendered butter_at(const Eigen::Vector3d& at) {
  synth::Scene s;
  s.world_from_camera = synth::workcell_camera();
  s.boxes = {Box{at, 0.2, Eigen::Vector3d(0.06, 0.04, 0.03), {240, 230, 100}}};
  return synth::render(s);
}

TEST(SceneObjects, ALookAlikesCandidateGoesToTheObjectItFitsBestAndTheOtherIsNotSeen) {
  // A butter-sized box whose pixels both a cream cheese's and a butter's colours claim (their masks are
  // the same pixels): the scene's order put the cream cheese first, and it took the butter; the box
  // fits the butter best, so the butter has it and the cream cheese, with nothing else, is not seen.
  const Eigen::Vector3d at(0.05, 0.0, 0.015);
  const auto r = butter_at(at);
  CloudParams p;
  p.support_z = 0;
  const auto est = estimate_objects(r.frame, {mask_of(r, 1, "cream_cheese"), mask_of(r, 1, "butter")},
                                    {object("cream_cheese", {0.07, 0.05, 0.035}), object("butter", {0.06, 0.04, 0.03})}, p);
  ASSERT_EQ(est.size(), 2u);
  EXPECT_EQ(est[0].entity, "cream_cheese");
  EXPECT_EQ(est[0].confidence, 0) << "the cream cheese took the butter";
  EXPECT_EQ(est[1].entity, "butter");
  ASSERT_GT(est[1].confidence, 0);
  EXPECT_LT((est[1].centroid - at).norm(), 0.005) << est[1].centroid.transpose();
}

TEST(SceneObjects, ACandidateOverAnObjectPlacedIsThatObjectNotALookAlike) {
  // The cream cheese's colour matched a patch of the table around the butter and the butter's rim (a
  // pale table, a cream box): its box lies over the butter and is near the cream cheese's size. It is
  // the same thing as the butter's own candidate, which fits the butter better: the cream cheese is
  // not seen.
  const Eigen::Vector3d at(0.05, 0.0, 0.015);
  const auto r = butter_at(at);
  const cv::Mat1b butter = synth::id_mask(r, 1);
  cv::Mat1b near, inner;
  cv::dilate(butter, near, cv::getStructuringElement(cv::MORPH_RECT, {15, 15}));
  cv::erode(butter, inner, cv::getStructuringElement(cv::MORPH_RECT, {3, 3}));
  const cv::Mat1b table_patch = near & ~inner;
  CloudParams p;
  p.support_z = 0;
  const std::vector<LookFor> objects{object("cream_cheese", {0.07, 0.05, 0.035}), object("butter", {0.06, 0.04, 0.03})};
  const std::vector<Mask> patch_only{{"cream_cheese", table_patch, 1.0}};
  const EntityEstimate alone = estimate_objects(r.frame, patch_only, {objects[0]}, p)[0];
  ASSERT_GT(alone.confidence, 0) << "alone, the patch would have been a cream cheese";
  EXPECT_LT((alone.centroid.head<2>() - at.head<2>()).norm(), 0.03) << "over the butter";
  const auto est = estimate_objects(r.frame, {patch_only[0], mask_of(r, 1, "butter")}, objects, p);
  EXPECT_EQ(est[0].confidence, 0) << "the cream cheese took the butter's place";
  ASSERT_GT(est[1].confidence, 0);
  EXPECT_LT((est[1].centroid - at).norm(), 0.005);
  // A patch with four of the butter's pixels is too little to be seen as it is; grown over depth it
  // becomes the butter's box, which the butter already has.
  cv::Mat1b ring, seed = cv::Mat1b::zeros(butter.size());
  cv::dilate(butter, ring, cv::getStructuringElement(cv::MORPH_RECT, {5, 5}));
  const cv::Rect b = cv::boundingRect(butter);
  seed(cv::Rect(b.x + b.width / 2, b.y + b.height / 2, 2, 2)) = 255;
  const Mask grown_patch{"cream_cheese", (near & ~ring) | seed, 1.0};
  const EntityEstimate grown = estimate_objects(r.frame, {grown_patch}, {objects[0]}, p)[0];
  ASSERT_GT(grown.confidence, 0) << "alone, the patch grows into a cream cheese";
  EXPECT_EQ(estimate_objects(r.frame, {grown_patch, mask_of(r, 1, "butter")}, objects, p)[0].confidence, 0)
      << "the cream cheese grew into the butter";
}

}  // namespace
}  // namespace dh::perception
