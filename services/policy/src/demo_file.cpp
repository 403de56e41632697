#include "dh/policy/demo_file.hpp"

#include <cstdint>
#include <fstream>
#include <sstream>

namespace dh::policy {

namespace {
constexpr int kDemoFormat = 2;

class Out {
 public:
  explicit Out(std::ofstream& o) : o_(o) {}
  template <class T>
  void pod(const T& v) { o_.write(reinterpret_cast<const char*>(&v), sizeof v); }
  template <class T>
  void array(const T* p, std::size_t n) {
    pod<std::uint64_t>(n);
    o_.write(reinterpret_cast<const char*>(p), static_cast<std::streamsize>(n * sizeof(T)));
  }
  void text(const std::string& s) { array(s.data(), s.size()); }

 private:
  std::ofstream& o_;
};

class In {
 public:
  In(std::ifstream& i, std::string what, std::uintmax_t size) : i_(i), what_(std::move(what)), size_(size) {}
  template <class T>
  T pod() {
    T v{};
    read(&v, sizeof v);
    return v;
  }
  template <class T>
  std::vector<T> array() {
    const auto n = pod<std::uint64_t>();
    const auto at = static_cast<std::uintmax_t>(i_.tellg());
    if (n > (size_ - at) / sizeof(T))  // more than the rest of the file holds: corrupt, not a huge allocation
      throw PolicyFileError(what_ + ": truncated or corrupt (an array of " + std::to_string(n) + " items where " +
                            std::to_string(size_ - at) + " bytes are left); collect the demonstrations again");
    std::vector<T> v(n);
    read(v.data(), n * sizeof(T));
    return v;
  }
  std::string text() {
    const auto c = array<char>();
    return {c.begin(), c.end()};
  }

 private:
  void read(void* p, std::size_t n) {
    i_.read(static_cast<char*>(p), static_cast<std::streamsize>(n));
    if (static_cast<std::size_t>(i_.gcount()) != n)
      throw PolicyFileError(what_ + ": truncated; collect the demonstrations again (dh train-policy without --reuse-demos)");
  }
  std::ifstream& i_;
  std::string what_;
  std::uintmax_t size_;
};
}  // namespace

void save_demos(const std::vector<Demo>& demos, const std::filesystem::path& file) {
  if (file.has_parent_path()) std::filesystem::create_directories(file.parent_path());
  const auto tmp = file.string() + ".tmp";
  {
    std::ofstream o(tmp, std::ios::binary | std::ios::trunc);
    o << "DHDEMOS " << kDemoFormat << "\n";
    Out out(o);
    out.pod<std::uint64_t>(demos.size());
    for (const auto& d : demos) {
      out.text(d.key);
      out.text(d.instruction);
      out.pod<std::uint64_t>(d.entities.size());
      for (const auto& e : d.entities) out.text(e);
      out.pod<std::uint64_t>(d.steps.size());
      for (std::size_t t = 0; t < d.steps.size(); ++t) {
        out.array(d.steps[t].proprio.data(), d.steps[t].proprio.size());
        out.pod(d.steps[t].gripper_command);
        out.array(d.steps[t].entities.data(), d.steps[t].entities.size());
        out.array(d.actions[t].data(), d.actions[t].size());
      }
    }
    if (!o) throw PolicyFileError("cannot write demonstrations to " + tmp);
  }
  std::filesystem::rename(tmp, file);
}

std::vector<Demo> load_demos(const std::filesystem::path& file) {
  const std::string what = "demonstrations " + file.string();
  std::ifstream i(file, std::ios::binary);
  if (!i) throw PolicyFileError(what + ": no such file; run dh train-policy without --reuse-demos to collect them");
  std::string line;
  std::getline(i, line);
  if (line != "DHDEMOS " + std::to_string(kDemoFormat))
    throw PolicyFileError(what + ": not a demonstration file of format " + std::to_string(kDemoFormat) +
                          " (first line '" + line.substr(0, 40) + "'); collect them again");
  In in(i, what, std::filesystem::file_size(file));
  const auto count = in.pod<std::uint64_t>();
  if (count > std::filesystem::file_size(file)) throw PolicyFileError(what + ": corrupt (demonstration count)");
  std::vector<Demo> demos(count);
  for (auto& d : demos) {
    d.key = in.text();
    d.instruction = in.text();
    d.entities.resize(in.pod<std::uint64_t>());
    for (auto& e : d.entities) e = in.text();
    const auto steps = in.pod<std::uint64_t>();
    for (std::uint64_t t = 0; t < steps; ++t) {
      StepRecord r;
      const auto p = in.array<float>();
      if (p.size() != r.proprio.size()) throw PolicyFileError(what + ": corrupt step record in " + d.key);
      std::copy(p.begin(), p.end(), r.proprio.begin());
      r.gripper_command = in.pod<float>();
      r.entities = in.array<float>();
      const auto a = in.array<double>();
      if (a.size() != static_cast<std::size_t>(kActionDims)) throw PolicyFileError(what + ": corrupt action in " + d.key);
      Action act;
      std::copy(a.begin(), a.end(), act.begin());
      d.steps.push_back(std::move(r));
      d.actions.push_back(act);
    }
  }
  return demos;
}

}  // namespace dh::policy
