#include "dh/sim/robot_model.hpp"

#include <urdf_parser/urdf_parser.h>

#include <fstream>
#include <sstream>

#include "dh/common/config.hpp"
#include "mjcf_text.hpp"

namespace dh::sim {

namespace {

using mjcf::num;

std::string vec3(const urdf::Vector3& v) { return num(v.x) + " " + num(v.y) + " " + num(v.z); }
std::string quat(const urdf::Rotation& r) {
  return num(r.w) + " " + num(r.x) + " " + num(r.y) + " " + num(r.z);
}
std::string pose_attrs(const urdf::Pose& p) {
  return "pos=\"" + vec3(p.position) + "\" quat=\"" + quat(p.rotation) + "\"";
}

enum class Collides { No, Arm, Gripper };

std::string geom_xml(const urdf::Geometry& g, const urdf::Pose& origin, Collides collides, bool capsule,
                     double friction, const std::string& name) {
  std::string type, size;
  switch (g.type) {
    case urdf::Geometry::BOX: {
      const auto& b = static_cast<const urdf::Box&>(g);
      type = "box";
      size = num(b.dim.x / 2) + " " + num(b.dim.y / 2) + " " + num(b.dim.z / 2);
      break;
    }
    case urdf::Geometry::CYLINDER: {
      const auto& c = static_cast<const urdf::Cylinder&>(g);
      type = capsule ? "capsule" : "cylinder";
      size = num(c.radius) + " " + num(c.length / 2);
      break;
    }
    case urdf::Geometry::SPHERE: {
      type = "sphere";
      size = num(static_cast<const urdf::Sphere&>(g).radius);
      break;
    }
    default:
      return "";  // meshes are not used by this project's robot files
  }
  std::string xml = "<geom type=\"" + type + "\" size=\"" + size + "\" " + pose_attrs(origin);
  if (!name.empty()) xml += " name=\"" + name + "\"";
  // Contact bits: the scene's geoms are contype 1, conaffinity 3 (scene_mjcf's default). Arm links
  // (contype 2, conaffinity 0) touch the scene but not each other nor the gripper: self-collision is
  // left out. The hand and fingers (1, 1) touch the scene and grip with their pads' friction.
  if (collides == Collides::Arm)
    xml += " contype=\"2\" conaffinity=\"0\" group=\"3\" rgba=\"0.9 0.5 0.2 0.4\"";
  else if (collides == Collides::Gripper)
    xml += " contype=\"1\" conaffinity=\"1\" condim=\"4\" friction=\"" + num(friction) +
           " 0.02 0.001\" rgba=\"0.9 0.9 0.9 1\"";
  else
    xml += " contype=\"0\" conaffinity=\"0\" group=\"1\" rgba=\"0.85 0.85 0.88 1\"";
  return xml + "/>\n";
}

/// `arm`: the link is the base or hangs from a revolute joint of the arm chain (not the hand's side).
void emit_link(const urdf::ModelInterface& model, const urdf::Link& link, bool arm, double finger_friction,
               std::string& out) {
  if (link.inertial) {
    const auto& in = *link.inertial;
    out += "<inertial pos=\"" + vec3(in.origin.position) + "\" mass=\"" + num(in.mass) +
           "\" diaginertia=\"" + num(in.ixx) + " " + num(in.iyy) + " " + num(in.izz) + "\"/>\n";
  }
  int i = 0;
  for (const auto& c : link.collision_array)
    if (c->geometry)
      out += geom_xml(*c->geometry, c->origin, arm ? Collides::Arm : Collides::Gripper, c->name == "capsule",
                      finger_friction, link.name + "_col" + std::to_string(i++));
  for (const auto& v : link.visual_array)
    if (v->geometry) out += geom_xml(*v->geometry, v->origin, Collides::No, false, 0, "");
  // The hand (the TCP's parent) carries the wrist camera, like LIBERO's robot0_eye_in_hand: beside the
  // hand (+x, across the jaw), looking along the tool axis (+z) with the jaw horizontal and the fingertips
  // at the bottom of the image. A camera has no mass and no contacts.
  for (const auto& child : link.child_links)
    if (child->name == "tcp") out += "<camera name=\"wrist\" pos=\"0.05 0 0.02\" xyaxes=\"0 1 0 1 0 0\" fovy=\"75\"/>\n";
  for (const auto& child : link.child_links) {
    const auto& j = *child->parent_joint;
    out += "<body name=\"" + child->name + "\" " + pose_attrs(j.parent_to_joint_origin_transform) +
           ">\n";
    if (j.type == urdf::Joint::REVOLUTE || j.type == urdf::Joint::PRISMATIC) {
      out += "<joint name=\"" + j.name + "\" type=\"" +
             (j.type == urdf::Joint::REVOLUTE ? "hinge" : "slide") + "\" axis=\"" + vec3(j.axis) +
             "\" range=\"" + num(j.limits->lower) + " " + num(j.limits->upper) +
             "\" limited=\"true\" armature=\"0.1\" damping=\"" +
             num(j.dynamics ? j.dynamics->damping : 0.0) + "\"/>\n";
    }
    if (child->name == "tcp") out += "<site name=\"tcp\" size=\"0.005\"/>\n";
    emit_link(model, *child, arm && j.type == urdf::Joint::REVOLUTE, finger_friction, out);
    out += "</body>\n";
  }
}

}  // namespace

RobotSpec load_robot(const std::filesystem::path& urdf_path) {
  std::ifstream in(urdf_path);
  if (!in) throw ConfigError(urdf_path.string() + ": robot URDF not found");
  std::stringstream buf;
  buf << in.rdbuf();
  urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(buf.str());
  if (!model) throw ConfigError(urdf_path.string() + ": not a valid URDF (urdfdom could not parse it)");
  RobotSpec spec;
  spec.urdf = urdf_path;
  spec.urdf_xml = buf.str();
  spec.name = model->getName();
  // Walk the chain from the root so joints come base to tip.
  std::vector<urdf::LinkConstSharedPtr> stack{model->getRoot()};
  while (!stack.empty()) {
    auto link = stack.back();
    stack.pop_back();
    for (auto it = link->child_links.rbegin(); it != link->child_links.rend(); ++it) {
      const auto& j = *(*it)->parent_joint;
      if (j.limits && (j.type == urdf::Joint::REVOLUTE || j.type == urdf::Joint::PRISMATIC)) {
        JointLimits l{j.name, j.limits->lower, j.limits->upper, j.limits->velocity, j.limits->effort};
        (j.type == urdf::Joint::REVOLUTE ? spec.arm : spec.fingers).push_back(l);
      }
      stack.push_back(*it);
    }
  }
  if (spec.arm.size() != 6 && spec.arm.size() != 7)
    throw ConfigError(urdf_path.string() + ": expected 6 or 7 revolute arm joints, found " +
                      std::to_string(spec.arm.size()));
  if (spec.fingers.empty())
    throw ConfigError(urdf_path.string() + ": expected prismatic finger joints, found none");
  if (!model->getLink(spec.tcp_link))
    throw ConfigError(urdf_path.string() + ": expected a link named 'tcp' (the tool centre point)");
  return spec;
}

MjcfFragments robot_mjcf(const RobotSpec& spec, const double base_pos[3], double finger_friction) {
  urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(spec.urdf_xml);
  if (!model) throw ConfigError(spec.urdf.string() + ": not a valid URDF");
  MjcfFragments f;
  f.body = "<body name=\"" + model->getRoot()->name + "\" pos=\"" + num(base_pos[0]) + " " +
           num(base_pos[1]) + " " + num(base_pos[2]) + "\">\n";
  emit_link(*model, *model->getRoot(), true, finger_friction, f.body);
  f.body += "</body>\n";
  for (const auto& j : spec.arm)
    f.actuators += "<motor name=\"" + j.name + "_motor\" joint=\"" + j.name +
                   "\" ctrllimited=\"true\" ctrlrange=\"" + num(-j.effort) + " " + num(j.effort) +
                   "\"/>\n";
  // One position servo drives the first finger; the others follow through the mimic equality.
  const auto& drive = spec.fingers.front();
  f.actuators += "<position name=\"gripper\" joint=\"" + drive.name + "\" kp=\"4000\" ctrllimited=\"true\" ctrlrange=\"" +
                 num(drive.lower) + " " + num(drive.upper) + "\" forcelimited=\"true\" forcerange=\"" +
                 num(-drive.effort / 2) + " " + num(drive.effort / 2) + "\"/>\n";
  for (std::size_t i = 1; i < spec.fingers.size(); ++i)
    f.equalities += "<joint joint1=\"" + spec.fingers[i].name + "\" joint2=\"" + drive.name +
                    "\" polycoef=\"0 1 0 0 0\"/>\n";
  return f;
}

}  // namespace dh::sim
