// Thin Fast DDS 2.x helpers: a participant pinned to the project's XML profile, typed writers and
// readers, and the QoS of every topic in one table (DESIGN.md §3).
//
// Readers deliver samples and QoS events (liveliness, deadline) through callbacks on the middleware's
// thread; nodes only push them into their own queue (see EventQueue) and decide on their own thread.
#pragma once

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>

#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

#include "dh/common/ports.hpp"

namespace dh::dds {

namespace fdds = eprosima::fastdds::dds;

struct QosPair {
  fdds::DataWriterQos writer;
  fdds::DataReaderQos reader;
};
QosPair qos_for(Qos kind);

/// Liveliness of announcements (capabilities, simulator channels) is MANUAL_BY_TOPIC: Fast DDS 2.9
/// (Debian 12) lets any remote participant's AUTOMATIC liveliness message assert every remote AUTOMATIC
/// writer (Fast-DDS #4373, fixed by #4501 in 2.13/2.14), so a killed capability would stay "alive" as
/// long as another one lives. A Heartbeat thread asserts it: a capability host's only while its event
/// loop has run recently (a stuck loop loses it), a simulator worker's (channels on threads of their own
/// behind one writer) always.
/// Liveliness lease of capability announcements and the lease-topic deadline, in seconds.
inline constexpr double kLivelinessLeaseSec = 1.0;
inline constexpr double kLeaseDeadlineSec = 1.0;
/// Liveliness lease of a simulator worker's channel announcements, in seconds.
inline constexpr double kChannelLivelinessSec = 2.0;

/// DDS domain: DH_DOMAIN_ID, default 42.
int domain_id();

class Participant {
 public:
  /// Creates a participant from the XML profile (paths::dds_profile()); throws std::runtime_error
  /// when the profile is missing or invalid, never falling back to default (multicast-everywhere)
  /// transports.
  explicit Participant(const std::string& name);
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  fdds::DomainParticipant* raw() const { return participant_; }
  fdds::Publisher* publisher() const { return publisher_; }
  fdds::Subscriber* subscriber() const { return subscriber_; }
  /// The topic `name` of `type`, created once.
  fdds::Topic* topic(const std::string& name, fdds::TypeSupport type);
  /// The topic `name` seen through the addressee filter (dds_addressee.hpp), created once.
  fdds::TopicDescription* addressed(const std::string& name, fdds::TypeSupport type);

 private:
  fdds::DomainParticipant* participant_ = nullptr;
  fdds::Publisher* publisher_ = nullptr;
  fdds::Subscriber* subscriber_ = nullptr;
  std::mutex mutex_;
  std::map<std::string, fdds::Topic*> topics_;
  std::map<std::string, fdds::TopicDescription*> filtered_;
};

template <class PubSub>
class Writer {
 public:
  using T = typename PubSub::type;
  Writer(Participant& p, const std::string& topic, Qos qos) : participant_(p) {
    writer_ = p.publisher()->create_datawriter(p.topic(topic, fdds::TypeSupport(new PubSub())),
                                               qos_for(qos).writer);
    if (!writer_) throw std::runtime_error("cannot create a writer on " + topic);
  }
  ~Writer() { participant_.publisher()->delete_datawriter(writer_); }
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  bool write(const T& sample) { return writer_->write(const_cast<T*>(&sample)); }
  /// Asserts a MANUAL_BY_TOPIC writer's liveliness (see Heartbeat).
  void assert_liveliness() { writer_->assert_liveliness(); }
  /// This writer's handle, as readers see it in SampleInfo::publication_handle.
  fdds::InstanceHandle_t handle() const { return writer_->get_instance_handle(); }
  /// Number of matched readers.
  std::size_t matched() const {
    fdds::PublicationMatchedStatus s;
    writer_->get_publication_matched_status(s);
    return static_cast<std::size_t>(s.current_count);
  }

 private:
  Participant& participant_;
  fdds::DataWriter* writer_ = nullptr;
};

/// Calls `beat` every `period` on a thread of its own until destroyed: keeps MANUAL_BY_TOPIC writers alive
/// for as long as the process lives, whatever its main loop is doing.
class Heartbeat {
 public:
  Heartbeat(std::function<void()> beat, std::chrono::milliseconds period);
  ~Heartbeat();
  Heartbeat(const Heartbeat&) = delete;
  Heartbeat& operator=(const Heartbeat&) = delete;

 private:
  std::mutex m_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::thread thread_;
};

template <class PubSub>
class Reader : public fdds::DataReaderListener {
 public:
  using T = typename PubSub::type;
  struct Callbacks {
    std::function<void(const T&, const fdds::SampleInfo&)> on_data;
    std::function<void(const fdds::LivelinessChangedStatus&)> on_liveliness;
    std::function<void(const fdds::RequestedDeadlineMissedStatus&)> on_deadline;
  };

  /// `addressed`: only the samples for this participant or for everyone (dds_addressee.hpp).
  Reader(Participant& p, const std::string& topic, Qos qos, Callbacks cb, bool addressed = false)
      : participant_(p), cb_(std::move(cb)) {
    fdds::StatusMask mask = fdds::StatusMask::data_available();
    if (cb_.on_liveliness) mask << fdds::StatusMask::liveliness_changed();
    if (cb_.on_deadline) mask << fdds::StatusMask::requested_deadline_missed();
    fdds::TypeSupport type(new PubSub());
    fdds::TopicDescription* t = addressed ? p.addressed(topic, type) : p.topic(topic, type);
    reader_ = p.subscriber()->create_datareader(t, qos_for(qos).reader, this, mask);
    if (!reader_) throw std::runtime_error("cannot create a reader on " + topic);
  }
  ~Reader() override {
    reader_->set_listener(nullptr);
    participant_.subscriber()->delete_datareader(reader_);
  }
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  std::size_t matched() const {
    fdds::SubscriptionMatchedStatus s;
    reader_->get_subscription_matched_status(s);
    return static_cast<std::size_t>(s.current_count);
  }

  void on_data_available(fdds::DataReader* reader) override {
    T sample;
    fdds::SampleInfo info;
    while (reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
      if (info.valid_data && cb_.on_data) cb_.on_data(sample, info);
    }
  }
  void on_liveliness_changed(fdds::DataReader*, const fdds::LivelinessChangedStatus& s) override {
    if (cb_.on_liveliness) cb_.on_liveliness(s);
  }
  void on_requested_deadline_missed(fdds::DataReader*,
                                    const fdds::RequestedDeadlineMissedStatus& s) override {
    if (cb_.on_deadline) cb_.on_deadline(s);
  }

 private:
  Participant& participant_;
  Callbacks cb_;
  fdds::DataReader* reader_ = nullptr;
};

}  // namespace dh::dds
