// Libraries with other θ (issue 16). `dh library perturb`: an untuned starting library nobody chose by
// hand; every revisable θ of every descriptor is drawn uniformly within its declared physical range (a
// whole number for a step count), from a generator seeded by the caller. A revision's candidate library:
// its parent with one capability's θ replaced. Everything else in the files is kept.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>

#include "dh/cap/skill.hpp"

namespace dh::evo {

struct PerturbedLibrary {
  std::string version;                      ///< lib-... of the drawn θ (cap::library_version)
  std::map<std::string, cap::Theta> theta;  ///< by capability, as drawn
};

/// Copies the library folder `from` to `out` (which must not exist or be empty), with the θ of each
/// capability in `theta` replaced and `note` as the first line of those files; returns the written
/// library's version. Throws std::invalid_argument naming `out` when it holds files, ConfigError when the
/// written library does not load (a value outside its range), std::runtime_error when it cannot be written
/// or does not read back as given.
std::string write_library(const std::filesystem::path& from, const std::map<std::string, cap::Theta>& theta,
                          const std::filesystem::path& out, const std::string& note);

/// Copies the library folder `from` to `out` (which must not exist or be empty) with every θ drawn for
/// `seed`; the draw is the same for the same library and seed (with this standard library's
/// distributions). Throws ConfigError for a library that does not load, std::invalid_argument naming `out`
/// when it holds files, std::runtime_error when it cannot be written.
PerturbedLibrary perturb_library(const std::filesystem::path& from, std::uint64_t seed,
                                 const std::filesystem::path& out);

}  // namespace dh::evo
