#include "dh/evo/registry.hpp"

#include <chrono>
#include <ctime>
#include <fstream>
#include <stdexcept>

#include "dh/common/digest.hpp"

namespace dh::evo {
namespace {

using nlohmann::json;

std::string utc_now() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

/// The chain's start: the hash an empty registry's next line carries.
const std::string kGenesis = sha256_hex(std::string_view("dh registry"));

}  // namespace

Registry::Registry(std::filesystem::path dir) : dir_(std::move(dir)) {}

std::vector<json> Registry::entries() const {
  std::vector<json> out;
  std::ifstream in(file());
  if (!in) return out;  // no registry yet
  std::string line, previous = kGenesis;
  for (std::size_t n = 1; std::getline(in, line); ++n) {
    json e;
    try {
      e = json::parse(line);
    } catch (const json::exception& ex) {
      throw std::runtime_error(file().string() + " line " + std::to_string(n) + " is not JSON (" + ex.what() +
                               ")");
    }
    if (e.value("previous", "") != previous)
      throw std::runtime_error(file().string() + " line " + std::to_string(n) +
                               ": the chain of hashes is broken (a line before it was edited, inserted or "
                               "removed); the registry is append-only");
    previous = sha256_hex(line);
    out.push_back(std::move(e));
  }
  return out;
}

std::optional<json> Registry::find(const std::string& id) const {
  for (auto& e : entries())
    if (e.value("id", "") == id) return e;
  return std::nullopt;
}

json Registry::append(json entry, const std::filesystem::path& library, bool admitted) {
  const std::vector<json> before = entries();  // also checks the chain before extending it
  std::string previous = kGenesis;
  {
    std::ifstream in(file());
    std::string line, last;
    while (std::getline(in, line)) last = line;
    if (!last.empty()) previous = sha256_hex(last);
  }
  entry["id"] = "r" + std::to_string(before.size() + 1);
  entry["time"] = utc_now();
  entry["decision"] = admitted ? "admitted" : "rejected";
  entry["previous"] = previous;
  if (admitted) {
    const std::string version = entry.at("candidate_version").get<std::string>();
    const auto snap = snapshot(version);
    if (!std::filesystem::exists(snap)) {  // content-addressed: the same θ is the same snapshot
      std::filesystem::create_directories(snap);
      for (const auto& f : std::filesystem::directory_iterator(library)) {
        if (!f.is_regular_file()) continue;
        std::filesystem::copy_file(f.path(), snap / f.path().filename());
        std::filesystem::permissions(snap / f.path().filename(), std::filesystem::perms::owner_read |
                                                                     std::filesystem::perms::group_read |
                                                                     std::filesystem::perms::others_read);
      }
    }
    entry["snapshot"] = snap.string();
  }
  std::filesystem::create_directories(dir_);
  std::ofstream out(file(), std::ios::app);
  out << entry.dump() << "\n";
  out.flush();
  if (!out) throw std::runtime_error("cannot append to " + file().string());
  return entry;
}

std::optional<std::filesystem::path> Registry::current() const {
  std::optional<std::filesystem::path> last;
  for (const auto& e : entries())
    if (e.value("decision", "") == "admitted") last = e.at("snapshot").get<std::string>();
  return last;
}

}  // namespace dh::evo
