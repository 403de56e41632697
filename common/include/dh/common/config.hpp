// Configuration loading with errors that name the file, the key path and the expected type.
#pragma once

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

namespace dh {

/// Thrown for any unusable configuration: missing file, bad YAML, missing key, wrong type.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A YAML node that remembers where it came from, so errors can say "file: key a.b.c: expected ...".
class ConfigNode {
 public:
  /// Parses `path`; throws ConfigError naming the file when it is missing or malformed.
  static ConfigNode load_file(const std::filesystem::path& path);
  /// Parses a YAML string; `origin` names it in errors.
  static ConfigNode load_string(const std::string& yaml, const std::string& origin);

  ConfigNode(YAML::Node node, std::string file, std::string key_path);

  bool has(const std::string& key) const;
  ConfigNode child(const std::string& key) const;  ///< throws if missing
  std::vector<ConfigNode> items(const std::string& key) const;  ///< a sequence; throws if missing
  std::vector<std::string> keys() const;  ///< keys of a map node

  template <class T>
  T get(const std::string& key) const;
  template <class T>
  T get_or(const std::string& key, const T& fallback) const {
    return has(key) ? get<T>(key) : fallback;
  }
  /// This node converted as a whole (for sequence items).
  template <class T>
  T as() const;

  const std::string& file() const { return file_; }
  const std::string& key_path() const { return key_path_; }
  std::filesystem::path dir() const { return std::filesystem::path(file_).parent_path(); }
  const YAML::Node& raw() const { return node_; }
  [[noreturn]] void fail(const std::string& key, const std::string& what) const;

 private:
  std::string sub_path(const std::string& key) const;
  YAML::Node node_;
  std::string file_;
  std::string key_path_;
};

template <class T>
const char* config_type_name();

template <class T>
T ConfigNode::as() const {
  try {
    return node_.as<T>();
  } catch (const YAML::Exception&) {
    throw ConfigError(file_ + ": key '" + key_path_ + "': expected " + config_type_name<T>());
  }
}

template <class T>
T ConfigNode::get(const std::string& key) const {
  if (!has(key)) fail(key, std::string("missing (expected ") + config_type_name<T>() + ")");
  return child(key).as<T>();
}

}  // namespace dh
