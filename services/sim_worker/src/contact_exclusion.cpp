#include "dh/sim/contact_exclusion.hpp"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>

#include "dh/common/digest.hpp"
#include "dh/sim/model.hpp"

namespace dh::sim {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kSlack = 0.001;  // m beyond the margins: rounding of poses, never a real gap
// m a slide may pass its range: a limit is a soft constraint, and a drawer slammed shut presses into it
constexpr double kOvertravel = 0.01;

struct Box {
  std::array<double, 3> lo{kInf, kInf, kInf}, hi{-kInf, -kInf, -kInf};
  void add(const Box& b) {
    for (int i = 0; i < 3; ++i) {
      lo[i] = std::min(lo[i], b.lo[i]);
      hi[i] = std::max(hi[i], b.hi[i]);
    }
  }
  bool disjoint(const Box& b, double gap) const {
    for (int i = 0; i < 3; ++i)
      if (lo[i] > b.hi[i] + gap || b.lo[i] > hi[i] + gap) return true;
    return false;
  }
};

/// A geom's world box at the pose in `d`: exact for boxes and spheres, a floor plane (normal up) holds
/// everything below its height, any other shape its bounding sphere, an unbounded one everything.
Box geom_box(const mjModel* m, const mjData* d, int g) {
  const double* p = d->geom_xpos + 3 * g;
  const double* r = d->geom_xmat + 9 * g;  // row-major: r[3 * i + j] = R(i, j)
  const double* s = m->geom_size + 3 * g;
  Box b;
  std::array<double, 3> half{};
  switch (m->geom_type[g]) {
    case mjGEOM_PLANE:
      b.lo = {-kInf, -kInf, -kInf};
      b.hi = {kInf, kInf, r[8] > 1 - 1e-9 ? p[2] : kInf};  // r[8]: its normal, the local z axis, points up
      return b;
    case mjGEOM_BOX:
      for (int i = 0; i < 3; ++i)
        half[i] = std::abs(r[3 * i]) * s[0] + std::abs(r[3 * i + 1]) * s[1] + std::abs(r[3 * i + 2]) * s[2];
      break;
    default:
      if (!(m->geom_rbound[g] > 0)) {
        b.lo = {-kInf, -kInf, -kInf};
        b.hi = {kInf, kInf, kInf};
        return b;
      }
      half = {m->geom_rbound[g], m->geom_rbound[g], m->geom_rbound[g]};
  }
  for (int i = 0; i < 3; ++i) {
    b.lo[i] = p[i] - half[i];
    b.hi[i] = p[i] + half[i];
  }
  return b;
}

enum class Motion { Static, Slides, Moves };

Motion motion_of(const mjModel* m, int body) {
  for (int b = body; b != 0; b = m->body_parentid[b])
    if (m->body_mocapid[b] >= 0) return Motion::Moves;  // welded to the world, and moved by whoever drives it
  const int weld = m->body_weldid[body];
  if (weld == 0) return Motion::Static;
  if (m->body_jntnum[weld] != 1 || m->body_weldid[m->body_parentid[weld]] != 0) return Motion::Moves;
  const int j = m->body_jntadr[weld];
  return m->jnt_type[j] == mjJNT_SLIDE && m->jnt_limited[j] ? Motion::Slides : Motion::Moves;
}

}  // namespace

std::vector<BodyPair> never_touching(const mjModel* m) {
  std::vector<Motion> motion(static_cast<std::size_t>(m->nbody));
  for (int b = 0; b < m->nbody; ++b) motion[b] = motion_of(m, b);
  // Every geom's box over its body's whole motion: at the model's reference pose and with every slide
  // joint at either end of its range and past it (a slide only translates its bodies, so the hull of the
  // two ends holds every pose between).
  const DataPtr data = make_data(m);
  mjData* d = data.get();
  std::vector<Box> swept(static_cast<std::size_t>(m->ngeom));
  for (int end = -1; end < 2; ++end) {
    std::copy_n(m->qpos0, m->nq, d->qpos);
    if (end >= 0)
      for (int j = 0; j < m->njnt; ++j)
        if (m->jnt_type[j] == mjJNT_SLIDE && m->jnt_limited[j])
          d->qpos[m->jnt_qposadr[j]] = m->jnt_range[2 * j + end] + (end == 0 ? -kOvertravel : kOvertravel);
    mj_kinematics(m, d);
    for (int g = 0; g < m->ngeom; ++g) swept[g].add(geom_box(m, d, g));
  }
  std::vector<BodyPair> out;
  for (int b1 = 0; b1 < m->nbody; ++b1)
    for (int b2 = b1 + 1; b2 < m->nbody; ++b2) {
      if (motion[b1] == Motion::Moves || motion[b2] == Motion::Moves) continue;
      // MuJoCo never collides two bodies of one weld group, the static ones among them.
      if (m->body_weldid[b1] == m->body_weldid[b2]) continue;
      const char* n1 = mj_id2name(m, mjOBJ_BODY, b1);
      const char* n2 = mj_id2name(m, mjOBJ_BODY, b2);
      if (!n1 || !n2) continue;  // an exclusion names its bodies
      bool any = false, apart = true;
      for (int g1 = m->body_geomadr[b1]; apart && g1 < m->body_geomadr[b1] + m->body_geomnum[b1]; ++g1)
        for (int g2 = m->body_geomadr[b2]; apart && g2 < m->body_geomadr[b2] + m->body_geomnum[b2]; ++g2) {
          if (!(m->geom_contype[g1] & m->geom_conaffinity[g2]) &&
              !(m->geom_contype[g2] & m->geom_conaffinity[g1]))
            continue;
          any = true;
          apart = swept[g1].disjoint(swept[g2], std::max(m->geom_margin[g1], m->geom_margin[g2]) + kSlack);
        }
      if (any && apart) out.emplace_back(n1, n2);
    }
  return out;
}

std::vector<BodyPair> never_touching(const std::string& xml, const std::string& origin, ModelPtr* compiled) {
  static std::mutex mutex;
  static std::map<std::pair<std::uint64_t, std::size_t>, std::vector<BodyPair>> known;
  const std::pair key(fnv1a64(xml.data(), xml.size()), xml.size());
  {
    std::lock_guard lock(mutex);
    if (const auto k = known.find(key); k != known.end()) return k->second;
  }
  ModelPtr m = compile_model(xml, origin);
  std::vector<BodyPair> pairs = never_touching(m.get());
  if (compiled) *compiled = std::move(m);
  std::lock_guard lock(mutex);
  return known.emplace(key, std::move(pairs)).first->second;
}

}  // namespace dh::sim
