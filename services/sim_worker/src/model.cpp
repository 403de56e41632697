#include "dh/sim/model.hpp"

#include <mujoco/mujoco.h>

#include <cstring>
#include <mutex>
#include <stdexcept>

namespace dh::sim {

void ModelDeleter::operator()(mjModel_* m) const { mj_deleteModel(m); }
void DataDeleter::operator()(mjData_* d) const { mj_deleteData(d); }

ModelPtr compile_model(const std::string& xml, const std::string& origin) {
  auto vfs = std::make_unique<mjVFS>();
  mj_defaultVFS(vfs.get());
  const char* fname = "workcell.xml";
  if (mj_makeEmptyFileVFS(vfs.get(), fname, static_cast<int>(xml.size())) != 0)
    throw std::runtime_error("MuJoCo VFS: cannot hold the model of " + origin);
  std::memcpy(vfs->filedata[mj_findFileVFS(vfs.get(), fname)], xml.data(), xml.size());
  char err[1024] = "";
  // mj_loadXML keeps process-wide state (the last model loaded, for mj_saveLastXML): one load at a time,
  // so simulator channels and parallel probes may compile their models from several threads.
  static std::mutex load;
  ModelPtr m;
  {
    std::lock_guard lock(load);
    m.reset(mj_loadXML(fname, vfs.get(), err, sizeof err));
  }
  mj_deleteVFS(vfs.get());
  if (!m) throw std::runtime_error(origin + ": MuJoCo rejected the workcell model: " + err);
  return m;
}

DataPtr make_data(const mjModel_* m) { return DataPtr(mj_makeData(m)); }

}  // namespace dh::sim
