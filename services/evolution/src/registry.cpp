#include "dh/evo/registry.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

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

Registry::Chain Registry::read_chain() const {
  Chain chain{{}, kGenesis};
  std::ifstream in(file());
  if (!in) {
    if (std::filesystem::exists(head()))
      throw std::runtime_error(file().string() + " is missing but " + head().string() + " says it had lines");
    return chain;  // no registry yet
  }
  std::string line;
  for (std::size_t n = 1; std::getline(in, line); ++n) {
    json e;
    try {
      e = json::parse(line);
    } catch (const json::exception& ex) {
      throw std::runtime_error(file().string() + " line " + std::to_string(n) + " is not JSON (" + ex.what() +
                               ")");
    }
    if (e.value("previous", "") != chain.last)
      throw std::runtime_error(file().string() + " line " + std::to_string(n) +
                               ": the chain of hashes is broken (a line before it was edited, inserted or "
                               "removed); the registry is append-only");
    chain.last = sha256_hex(line);
    chain.entries.push_back(std::move(e));
  }
  // The last line has no successor to carry its hash: the head file does.
  std::ifstream head_in(head());
  std::string head_hash;
  std::getline(head_in, head_hash);
  if (head_hash != chain.last)
    throw std::runtime_error(
        file().string() + ": its last line does not match " + head().string() +
        " (the last line was edited or removed, or an append was cut short); the registry is "
        "append-only");
  return chain;
}

std::vector<json> Registry::entries() const { return read_chain().entries; }

std::optional<json> Registry::find(const std::string& id) const {
  for (auto& e : entries())
    if (e.value("id", "") == id) return e;
  return std::nullopt;
}

json Registry::append(json entry, const std::filesystem::path& library, bool admitted) {
  std::filesystem::create_directories(dir_);
  // One writer at a time: the lock is held from reading the chain to writing the new head.
  const int lock = ::open((dir_ / "registry.lock").c_str(), O_CREAT | O_RDWR, 0644);
  if (lock < 0) throw std::runtime_error("cannot open " + (dir_ / "registry.lock").string());
  struct Unlock {
    int fd;
    ~Unlock() { ::close(fd); }  // closing releases the lock
  } unlock{lock};
  if (::flock(lock, LOCK_EX) != 0)
    throw std::runtime_error("cannot lock " + (dir_ / "registry.lock").string());

  const Chain chain = read_chain();  // checks the chain before extending it
  entry["id"] = "r" + std::to_string(chain.entries.size() + 1);
  entry["time"] = utc_now();
  entry["decision"] = admitted ? "admitted" : "rejected";
  entry["previous"] = chain.last;
  if (admitted) {
    const std::string version = entry.at("candidate_version").get<std::string>();
    const auto snap = snapshot(version);
    if (!std::filesystem::exists(snap)) {  // the same θ is the same snapshot
      // Copied whole, then renamed into place: a snapshot is never seen half written.
      const auto partial = dir_ / "snapshots" / (version + ".partial");
      std::filesystem::remove_all(partial);
      std::filesystem::create_directories(partial);
      for (const auto& f : std::filesystem::directory_iterator(library)) {
        if (!f.is_regular_file()) continue;
        std::filesystem::copy_file(f.path(), partial / f.path().filename());
        std::filesystem::permissions(partial / f.path().filename(), std::filesystem::perms::owner_read |
                                                                        std::filesystem::perms::group_read |
                                                                        std::filesystem::perms::others_read);
      }
      std::filesystem::rename(partial, snap);
    }
    entry["snapshot"] = snap.string();
  }
  const std::string line = entry.dump();
  {
    std::ofstream out(file(), std::ios::app);
    out << line << "\n";
    out.flush();
    if (!out) throw std::runtime_error("cannot append to " + file().string());
  }
  std::ofstream head_out(head(), std::ios::trunc);
  head_out << sha256_hex(line) << "\n";
  if (!head_out.flush()) throw std::runtime_error("cannot write " + head().string());
  return entry;
}

std::optional<std::filesystem::path> Registry::current() const {
  std::optional<std::filesystem::path> last;
  for (const auto& e : entries())
    if (e.value("decision", "") == "admitted") last = e.at("snapshot").get<std::string>();
  return last;
}

}  // namespace dh::evo
