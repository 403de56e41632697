#include "dh/evo/perturb.hpp"

#include <spdlog/fmt/fmt.h>

#include <cmath>
#include <fstream>
#include <random>
#include <regex>
#include <sstream>
#include <stdexcept>

#include "dh/cap/library_theta.hpp"

namespace dh::evo {
namespace {

std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// `text` with each parameter's value in its `parameters:` block replaced by `theta`'s; comments kept.
std::string with_theta(const std::string& text, const cap::Theta& theta) {
  static const std::regex entry(R"(^(\s+)([A-Za-z_][A-Za-z0-9_]*)(:\s*)([^#\s]+)(.*)$)");
  std::istringstream in(text);
  std::string out, line;
  bool in_parameters = false;
  while (std::getline(in, line)) {
    if (!line.empty() && !std::isspace(static_cast<unsigned char>(line[0])))
      in_parameters = line.rfind("parameters:", 0) == 0;
    std::smatch m;
    if (in_parameters && std::regex_match(line, m, entry)) {
      const auto it = theta.find(m[2].str());
      if (it != theta.end())
        line = m[1].str() + m[2].str() + m[3].str() + fmt::format("{}", it->second) + m[5].str();
    }
    out += line + "\n";
  }
  return out;
}

}  // namespace

std::string write_library(const std::filesystem::path& from, const std::map<std::string, cap::Theta>& theta,
                          const std::filesystem::path& out, const std::string& note) {
  if (std::filesystem::exists(out) && !std::filesystem::is_empty(out))
    throw std::invalid_argument(out.string() + " holds files: give `--out` a new or empty folder");
  std::filesystem::create_directories(out);
  for (const auto& e : std::filesystem::directory_iterator(from)) {
    if (e.path().extension() != ".yaml") continue;
    std::string text = read_text(e.path());
    if (const auto t = theta.find(e.path().stem().string()); t != theta.end())
      text = "# " + note + "\n" + with_theta(text, t->second);
    std::ofstream o(out / e.path().filename());
    o << text;
    if (!o) throw std::runtime_error("cannot write " + (out / e.path().filename()).string());
  }
  // What was written is what was given: the files load, within their ranges, with exactly this θ.
  const cap::LibraryTheta written = cap::load_library_theta(out);
  for (const auto& [capability, t] : theta)
    if (written.theta.at(capability) != t)
      throw std::runtime_error("the library written to " + out.string() + " does not read back " +
                               capability + "'s θ as given");
  return written.version;
}

PerturbedLibrary perturb_library(const std::filesystem::path& from, std::uint64_t seed,
                                 const std::filesystem::path& out) {
  const cap::LibraryTheta lib = cap::load_library_theta(from);
  // One generator, capabilities and parameters in name order: the same library and seed draw the same θ.
  std::mt19937_64 rng(seed);
  PerturbedLibrary p;
  for (const auto& [capability, theta] : lib.theta) {
    const cap::ThetaRanges& ranges = lib.ranges.at(capability);
    cap::Theta& drawn = p.theta[capability];
    for (const auto& [name, value] : theta) {
      const cap::ParameterRange& r = ranges.at(name);
      if (r.unit == "steps")
        drawn[name] = static_cast<double>(
            std::uniform_int_distribution<long>(std::lround(r.min), std::lround(r.max))(rng));
      else
        drawn[name] = std::uniform_real_distribution<double>(r.min, r.max)(rng);
    }
  }
  p.version = write_library(from, p.theta, out,
                            "θ drawn uniformly within its ranges by `dh library perturb --seed " +
                                std::to_string(seed) + "` from " + from.string());
  return p;
}

}  // namespace dh::evo
