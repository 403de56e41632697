// Compiling an MJCF document held in memory into a MuJoCo model.
#pragma once

#include <memory>
#include <string>

struct mjModel_;
struct mjData_;

namespace dh::sim {

struct ModelDeleter {
  void operator()(mjModel_* m) const;
};
struct DataDeleter {
  void operator()(mjData_* d) const;
};
using ModelPtr = std::unique_ptr<mjModel_, ModelDeleter>;
using DataPtr = std::unique_ptr<mjData_, DataDeleter>;

/// Compiles `xml`; throws std::runtime_error with `origin` and MuJoCo's message when it is rejected.
ModelPtr compile_model(const std::string& xml, const std::string& origin);
DataPtr make_data(const mjModel_* m);

}  // namespace dh::sim
