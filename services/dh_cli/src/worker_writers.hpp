// Which simulator worker wrote each channel announcement, so that a liveliness change of a writer names
// its worker: `dh campaign` loses what a lost worker ran, and `dh view` shows its channels as lost; both
// take the worker back when its announcements are alive again (it was starved, not dead).
#pragma once

#include <map>
#include <optional>
#include <string>

#include "dh/common/dds.hpp"

namespace dh::cli {

class WorkerWriters {
 public:
  /// A channel announcement from `worker` arrived through `writer`.
  void saw(const eprosima::fastdds::dds::InstanceHandle_t& writer, const std::string& worker) {
    worker_of_[writer] = worker;
  }

  struct Change {
    std::string worker;
    bool alive = false;  ///< its announcements are alive again; false: they lost liveliness
  };
  /// The worker a liveliness change is about; none when nothing changed or the writer has announced
  /// nothing yet (its first discovery: its announcements follow).
  std::optional<Change> changed(const eprosima::fastdds::dds::LivelinessChangedStatus& st) const {
    if (st.alive_count_change == 0) return std::nullopt;
    const auto it = worker_of_.find(st.last_publication_handle);
    if (it == worker_of_.end()) return std::nullopt;
    return Change{it->second, st.alive_count_change > 0};
  }

 private:
  std::map<eprosima::fastdds::dds::InstanceHandle_t, std::string> worker_of_;
};

}  // namespace dh::cli
