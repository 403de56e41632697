#include "dh/common/dds.hpp"

#include <cstdlib>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/topic/ContentFilteredTopic.hpp>
#include <filesystem>

#include "dh/common/dds_addressee.hpp"
#include "dh/common/paths.hpp"

namespace dh::dds {

namespace {
eprosima::fastrtps::Duration_t seconds(double s) { return eprosima::fastrtps::Duration_t(s); }
constexpr const char* kProfileName = "dh_participant";
}  // namespace

QosPair qos_for(Qos kind) {
  QosPair q;
  auto& w = q.writer;
  auto& r = q.reader;
  w.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  r.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
  w.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
  r.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
  w.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  r.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
  // Our types hold strings and sequences (unbounded), so data-sharing cannot apply; turning it off
  // also avoids the fast_datasharing_* files a killed process would leave in /dev/shm.
  w.data_sharing().off();
  r.data_sharing().off();
  // A sample that reaches a reader before the reader has matched its writer is dropped and repaired only
  // at the writer's next heartbeat, by default 3 s later. Seen: a capability's transient-local
  // announcement reached the governor exactly 3 s after it was written, in about one start in four under
  // ctest, and the governor refused the first episode. Heartbeats are only sent while a sample is
  // unacknowledged, so a short period costs nothing at rest.
  w.reliable_writer_qos().times.heartbeatPeriod = seconds(0.2);
  int depth = 1;
  switch (kind) {
    case Qos::Announce:
      w.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
      r.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
      w.liveliness().kind = fdds::MANUAL_BY_TOPIC_LIVELINESS_QOS;
      r.liveliness().kind = fdds::MANUAL_BY_TOPIC_LIVELINESS_QOS;
      w.liveliness().lease_duration = seconds(kLivelinessLeaseSec);
      r.liveliness().lease_duration = seconds(kLivelinessLeaseSec);
      depth = 1;
      break;
    case Qos::Lease:
      w.deadline().period = seconds(kLeaseDeadlineSec);
      r.deadline().period = seconds(kLeaseDeadlineSec);
      depth = 1;
      break;
    case Qos::Observation:
      // A late-joining governor or capability still gets the channel's latest observation.
      w.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
      r.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
      depth = 1;
      break;
    case Qos::Command:
    case Qos::Action:
      depth = 1;
      break;
    case Qos::Status:
      depth = 16;
      break;
    case Qos::Planner:
      depth = 8;
      break;
    case Qos::Verdict:
      w.history().kind = fdds::KEEP_ALL_HISTORY_QOS;
      r.history().kind = fdds::KEEP_ALL_HISTORY_QOS;
      break;
    case Qos::Episode:
      w.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
      r.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
      depth = 1;
      break;
    case Qos::ChannelStatus:
      w.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
      r.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
      w.liveliness().kind = fdds::MANUAL_BY_TOPIC_LIVELINESS_QOS;
      r.liveliness().kind = fdds::MANUAL_BY_TOPIC_LIVELINESS_QOS;
      w.liveliness().lease_duration = seconds(kChannelLivelinessSec);
      r.liveliness().lease_duration = seconds(kChannelLivelinessSec);
      depth = 1;
      break;
    case Qos::Camera:
      // Only the newest image of each camera matters; a late joiner (a capability swapped in) gets it at
      // once. A 224x224 RGB8 sample (150 KB) is sent in fragments of the smallest transport message
      // (UDPv4: 64 KB); a lost fragment is repaired at the next heartbeat, so beat faster than the 3 s
      // default.
      w.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
      r.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
      w.reliable_writer_qos().times.heartbeatPeriod = seconds(0.1);
      depth = 1;
      break;
    case Qos::Rgbd:
      // Reliable, volatile, keep-last 1 per (channel, camera): a 640x480 frame is 1.5 MB, 24 UDP fragments
      // of 64 KB over loopback (no shared memory: deploy/dds/loopback.xml), into a receive socket buffer of
      // the kernel's default 208 KB. Measured with tests/cameras/bench_rgbd_qos (two processes, 200
      // requests each; numbers in tests/cameras/README.md): best effort lost 40-45 % of the frames (any
      // lost fragment loses the frame) even at 30 Hz; reliable lost none, request -> frame p50 0.5 ms, p99 20-30 ms
      // (fragments repaired after the heartbeat piggybacked on each write). Keep-last 1: only the newest
      // frame of a camera matters; volatile: a late joiner asks, it does not get an old frame.
      w.reliable_writer_qos().times.heartbeatPeriod = seconds(0.1);
      depth = 1;
      break;
    case Qos::RgbdRequest:
      // Several consumers may ask the same channel at once (the topic is not keyed), and perception asks
      // two cameras per channel with a parts camera. A keep-last writer replaces its oldest sample once
      // `depth` are in its history: at 8, a campaign's 4 channels x 2 cameras left 78 frames unanswered
      // until the 2 s timeout in its first two minutes (goal tasks 0 and 7: 53/80, W 0 L 7 against no parts
      // camera); at 64, 5 at the deployment's start and 60/80, W 0 L 0 (b6002be).
      depth = 64;
      break;
  }
  w.history().depth = depth;
  r.history().depth = depth;
  // Fast DDS 2.x defaults to 10 instances per writer/reader; a key per channel needs many more.
  for (auto* rl : {&w.resource_limits(), &r.resource_limits()}) {
    rl->max_instances = 1024;
    rl->max_samples_per_instance = 400;
    rl->max_samples = 1024 * 400;
  }
  return q;
}

int domain_id() {
  const char* v = std::getenv("DH_DOMAIN_ID");
  if (!v || !*v) return 42;
  char* end = nullptr;
  long id = std::strtol(v, &end, 10);
  if (*end != '\0' || id < 0 || id > 232)
    throw std::runtime_error(std::string("DH_DOMAIN_ID='") + v + "' is not a DDS domain id (0-232)");
  return static_cast<int>(id);
}

Heartbeat::Heartbeat(std::function<void()> beat, std::chrono::milliseconds period)
    : thread_([this, beat = std::move(beat), period] {
        std::unique_lock l(m_);
        while (!stop_) {
          beat();
          cv_.wait_for(l, period, [this] { return stop_; });
        }
      }) {}

Heartbeat::~Heartbeat() {
  {
    std::lock_guard l(m_);
    stop_ = true;
  }
  cv_.notify_all();
  thread_.join();
}

Participant::Participant(const std::string& name) {
  auto* factory = fdds::DomainParticipantFactory::get_instance();
  const std::filesystem::path profile = paths::dds_profile();
  if (!std::filesystem::exists(profile))
    throw std::runtime_error("DDS profile " + profile.string() +
                             " not found; set DH_DDS_PROFILE to a Fast DDS XML profile");
  if (factory->load_XML_profiles_file(profile.string()) != ReturnCode_t::RETCODE_OK)
    throw std::runtime_error("DDS profile " + profile.string() + " is not a valid Fast DDS XML file");
  fdds::DomainParticipantQos qos;
  if (factory->get_participant_qos_from_profile(kProfileName, qos) != ReturnCode_t::RETCODE_OK)
    throw std::runtime_error("DDS profile " + profile.string() + " has no participant profile '" +
                             kProfileName + "'");
  qos.name(name);
  participant_ = factory->create_participant(domain_id(), qos);
  if (!participant_) throw std::runtime_error("cannot create DDS participant " + name);
  // Registered everywhere: a reader's filter is evaluated by the writer's participant (dds_addressee.hpp).
  if (participant_->register_content_filter_factory(kAddresseeFilter, &AddresseeFilterFactory::instance()) !=
      ReturnCode_t::RETCODE_OK)
    throw std::runtime_error("cannot register the content filter " + std::string(kAddresseeFilter));
  publisher_ = participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  subscriber_ = participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  if (!publisher_ || !subscriber_) throw std::runtime_error("cannot create publisher/subscriber");
}

Participant::~Participant() {
  if (!participant_) return;
  participant_->delete_contained_entities();
  fdds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
}

fdds::Topic* Participant::topic(const std::string& name, fdds::TypeSupport type) {
  std::lock_guard lock(mutex_);
  if (auto it = topics_.find(name); it != topics_.end()) return it->second;
  type.register_type(participant_);
  fdds::Topic* t = participant_->create_topic(name, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  if (!t) throw std::runtime_error("cannot create topic " + name);
  topics_[name] = t;
  return t;
}

fdds::TopicDescription* Participant::addressed(const std::string& name, fdds::TypeSupport type) {
  fdds::Topic* related = topic(name, type);
  std::lock_guard lock(mutex_);
  const std::string filtered = name + "|addressed";
  if (auto it = filtered_.find(filtered); it != filtered_.end()) return it->second;
  fdds::ContentFilteredTopic* t = participant_->create_contentfilteredtopic(
      filtered, related, kAddresseeExpression, {participant_address(participant_->guid())}, kAddresseeFilter);
  if (!t) throw std::runtime_error("cannot filter topic " + name + " by addressee");
  filtered_[filtered] = t;
  return t;
}

}  // namespace dh::dds
