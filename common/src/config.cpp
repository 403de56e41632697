#include "dh/common/config.hpp"

#include <cstdint>

namespace dh {

template <> const char* config_type_name<std::string>() { return "a string"; }
template <> const char* config_type_name<double>() { return "a number"; }
template <> const char* config_type_name<int>() { return "an integer"; }
template <> const char* config_type_name<unsigned>() { return "a non-negative integer"; }
template <> const char* config_type_name<std::uint64_t>() { return "a non-negative integer"; }
template <> const char* config_type_name<bool>() { return "true or false"; }
template <> const char* config_type_name<std::vector<double>>() { return "a list of numbers"; }
template <> const char* config_type_name<std::vector<int>>() { return "a list of integers"; }
template <> const char* config_type_name<std::vector<std::string>>() { return "a list of strings"; }

ConfigNode ConfigNode::load_file(const std::filesystem::path& path) {
  if (!std::filesystem::exists(path))
    throw ConfigError(path.string() + ": file not found (check the path or DH_CONFIG_DIR)");
  try {
    return ConfigNode(YAML::LoadFile(path.string()), path.string(), "");
  } catch (const YAML::Exception& e) {
    throw ConfigError(path.string() + ": malformed YAML at line " + std::to_string(e.mark.line + 1) +
                      ": " + e.msg);
  }
}

ConfigNode ConfigNode::load_string(const std::string& yaml, const std::string& origin) {
  try {
    return ConfigNode(YAML::Load(yaml), origin, "");
  } catch (const YAML::Exception& e) {
    throw ConfigError(origin + ": malformed YAML at line " + std::to_string(e.mark.line + 1) + ": " +
                      e.msg);
  }
}

ConfigNode::ConfigNode(YAML::Node node, std::string file, std::string key_path)
    : node_(std::move(node)), file_(std::move(file)), key_path_(std::move(key_path)) {}

std::string ConfigNode::sub_path(const std::string& key) const {
  return key_path_.empty() ? key : key_path_ + "." + key;
}

void ConfigNode::fail(const std::string& key, const std::string& what) const {
  throw ConfigError(file_ + ": key '" + sub_path(key) + "': " + what);
}

bool ConfigNode::has(const std::string& key) const {
  return node_.IsMap() && node_[key].IsDefined() && !node_[key].IsNull();
}

ConfigNode ConfigNode::child(const std::string& key) const {
  if (!has(key)) fail(key, "missing");
  return ConfigNode(node_[key], file_, sub_path(key));
}

std::vector<ConfigNode> ConfigNode::items(const std::string& key) const {
  ConfigNode list = child(key);
  if (!list.node_.IsSequence()) fail(key, "expected a list");
  std::vector<ConfigNode> out;
  for (std::size_t i = 0; i < list.node_.size(); ++i)
    out.emplace_back(list.node_[i], file_, list.key_path_ + "[" + std::to_string(i) + "]");
  return out;
}

std::vector<std::string> ConfigNode::keys() const {
  std::vector<std::string> out;
  if (!node_.IsMap()) return out;
  for (const auto& kv : node_) out.push_back(kv.first.as<std::string>());
  return out;
}

}  // namespace dh
