#include "dh/policy/model.hpp"

#include "dh/common/digest.hpp"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace dh::policy {

namespace {
constexpr const char* kMagic = "DHPOLICY";

void append(std::string& out, const float* p, std::size_t n) {
  out.append(reinterpret_cast<const char*>(p), n * sizeof(float));
}
}  // namespace

Eigen::VectorXf PolicyModel::normalise(const Eigen::VectorXf& f) const {
  return (f - feature_mean).cwiseQuotient(feature_scale);
}

std::vector<Action> PolicyModel::act(const Observation& obs, const std::string& instruction,
                                     double gripper_command) const {
  Eigen::VectorXf f(spec.size());
  encode(spec, record(obs, gripper_command), spec.slots(entity_names(obs)), spec.word_indices(instruction), f.data());
  const Eigen::VectorXf y = net.forward(normalise(f));
  std::vector<Action> out(static_cast<std::size_t>(chunk));
  for (int k = 0; k < chunk; ++k)
    for (int d = 0; d < kActionDims; ++d) out[k][d] = std::clamp(static_cast<double>(y[k * kActionDims + d]), -1.0, 1.0);
  return out;
}

void save_policy(PolicyModel& m, const std::filesystem::path& file) {
  std::string payload;
  append(payload, m.feature_mean.data(), m.feature_mean.size());
  append(payload, m.feature_scale.data(), m.feature_scale.size());
  for (const auto& l : m.net.layers()) {
    append(payload, l.w.data(), l.w.size());  // column-major
    append(payload, l.b.data(), l.b.size());
  }
  m.checksum = sha256_hex(payload.data(), payload.size());
  nlohmann::json h{{"format", kWeightFormat},
                   {"model", "mlp"},
                   {"layer_sizes", m.net.sizes()},
                   {"chunk", m.chunk},
                   {"action_dims", kActionDims},
                   {"entities", m.spec.entities},
                   {"words", m.spec.words},
                   {"training", m.training},
                   {"payload_bytes", payload.size()},
                   {"payload_sha256", m.checksum}};
  if (file.has_parent_path()) std::filesystem::create_directories(file.parent_path());
  const auto tmp = file.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << kMagic << " " << kWeightFormat << "\n" << h.dump() << "\n";
    out.write(payload.data(), static_cast<std::streamsize>(payload.size()));
    if (!out) throw PolicyFileError("cannot write policy weights to " + tmp);
  }
  std::filesystem::rename(tmp, file);  // a reader never sees half a file
}

PolicyModel load_policy(const std::filesystem::path& file) {
  const std::string what = "policy weights " + file.string();
  std::ifstream in(file, std::ios::binary);
  if (!in) throw PolicyFileError(what + ": no such file; train one with `dh train-policy`");
  std::string magic_line, header_line;
  std::getline(in, magic_line);
  std::istringstream ml(magic_line);
  std::string magic;
  int format = 0;
  ml >> magic >> format;
  if (magic != kMagic) throw PolicyFileError(what + ": not a DynaHarness policy file (no DHPOLICY line)");
  if (format != kWeightFormat)
    throw PolicyFileError(what + ": format " + std::to_string(format) + ", this build reads format " +
                          std::to_string(kWeightFormat) + "; retrain with `dh train-policy`");
  std::getline(in, header_line);
  nlohmann::json h;
  try {
    h = nlohmann::json::parse(header_line);
  } catch (const nlohmann::json::exception& e) {
    throw PolicyFileError(what + ": header is not JSON (" + e.what() + ")");
  }
  PolicyModel m;
  std::string payload;
  try {
    m.spec.entities = h.at("entities").get<std::vector<std::string>>();
    m.spec.words = h.at("words").get<std::vector<std::string>>();
    m.chunk = h.at("chunk").get<int>();
    m.training = h.value("training", nlohmann::json::object());
    m.checksum = h.at("payload_sha256").get<std::string>();
    const auto sizes = h.at("layer_sizes").get<std::vector<int>>();
    const auto bytes = h.at("payload_bytes").get<std::size_t>();
    if (bytes > std::filesystem::file_size(file))
      throw PolicyFileError(what + ": payload is truncated (the header announces " + std::to_string(bytes) + " bytes)");
    if (h.at("action_dims").get<int>() != kActionDims || sizes.size() < 2 || sizes.front() != m.spec.size() ||
        sizes.back() != m.chunk * kActionDims)
      throw PolicyFileError(what + ": layer sizes do not match the feature and action sizes in its header");
    payload.resize(bytes);
    in.read(payload.data(), static_cast<std::streamsize>(bytes));
    if (static_cast<std::size_t>(in.gcount()) != bytes || in.peek() != std::char_traits<char>::eof())
      throw PolicyFileError(what + ": payload is " + (static_cast<std::size_t>(in.gcount()) != bytes ? "truncated" : "longer than its header says") +
                            "; retrain or copy the file again");
    const std::string sum = sha256_hex(payload.data(), payload.size());
    if (sum != m.checksum)
      throw PolicyFileError(what + ": checksum mismatch (header " + m.checksum.substr(0, 12) + ", payload " +
                            sum.substr(0, 12) + "); the file is corrupt: retrain or copy it again");
    m.net = Mlp(sizes, 0);
  } catch (const nlohmann::json::exception& e) {
    throw PolicyFileError(what + ": header field missing or mistyped (" + e.what() + ")");
  }
  const float* p = reinterpret_cast<const float*>(payload.data());
  std::size_t need = 2 * static_cast<std::size_t>(m.spec.size());
  for (const auto& l : m.net.layers()) need += l.w.size() + l.b.size();
  if (need * sizeof(float) != payload.size())
    throw PolicyFileError(what + ": payload size does not match its layer sizes");
  auto take = [&](float* dst, std::size_t n) {
    std::copy(p, p + n, dst);
    p += n;
  };
  m.feature_mean.resize(m.spec.size());
  m.feature_scale.resize(m.spec.size());
  take(m.feature_mean.data(), m.feature_mean.size());
  take(m.feature_scale.data(), m.feature_scale.size());
  for (auto& l : m.net.layers()) {
    take(l.w.data(), l.w.size());
    take(l.b.data(), l.b.size());
  }
  return m;
}

}  // namespace dh::policy
