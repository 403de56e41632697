// A DDS participant for the security tests, run as its own process so that each one carries the identity
// its DH_DDS_PROFILE gives it (a service's, one from another CA, none at all): it tries to read and write
// DynaHarness topics and reports what happened. Every 200 ms, and once more when it ends (SIGTERM or
// --seconds), it writes one JSON object to --status FILE (and prints it on stdout): whether the
// participant, each reader and each writer could be created (and Fast DDS's errors when not), the samples
// read per topic, the episode ids, command ids and capabilities seen, the steps observed per episode, the
// remote participants discovered, authenticated and refused, and the most remote readers each writer matched.
//
//   sec_probe --status FILE [--seconds S] [--read TOPIC]... [--write TOPIC]...
//             [--request EPISODE_ID --channel N] [--act COMMAND_ID --episode EPISODE_ID --channel N]
//
// --write only creates the writer; --request writes one episode request (goal, task 8, seed 1); --act
// writes an action for EPISODE_ID every 50 ms, steps 0, 1, 2, ...
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/log/Log.hpp>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "dh/common/dds.hpp"
#include "dh/common/shutdown.hpp"
#include "dh/common/topics.hpp"
#include "dh/msg/capabilityPubSubTypes.h"
#include "dh/msg/commandPubSubTypes.h"
#include "dh/msg/episodePubSubTypes.h"
#include "dh/msg/robotPubSubTypes.h"

namespace {

using namespace dh;
using Clock = std::chrono::steady_clock;
namespace fdds = eprosima::fastdds::dds;

/// Keeps Fast DDS's error messages (e.g. why access control refused an entity).
class Collect : public fdds::LogConsumer {
 public:
  explicit Collect(std::shared_ptr<std::vector<std::string>> out, std::shared_ptr<std::mutex> m)
      : out_(std::move(out)), m_(std::move(m)) {}
  void Consume(const fdds::Log::Entry& e) override {
    if (e.kind != fdds::Log::Error) return;
    std::lock_guard l(*m_);
    if (out_->size() < 50)
      out_->push_back(std::string(e.context.category ? e.context.category : "") + ": " + e.message);
  }

 private:
  std::shared_ptr<std::vector<std::string>> out_;
  std::shared_ptr<std::mutex> m_;
};

struct Report {
  std::mutex m;
  nlohmann::json j = {{"participant", "not created"},
                      {"readers", nlohmann::json::object()},
                      {"writers", nlohmann::json::object()},
                      {"samples", nlohmann::json::object()},
                      {"matched", nlohmann::json::object()},
                      {"episodes", nlohmann::json::array()},
                      {"steps", nlohmann::json::object()},
                      {"seam_commands", nlohmann::json::array()},
                      {"capabilities", nlohmann::json::array()},
                      {"participants", {{"discovered", 0}, {"authorized", 0}, {"unauthorized", 0}}},
                      {"done", false}};
  std::set<std::string> episodes, seam_commands, capabilities;

  void sample(const std::string& topic) {
    std::lock_guard l(m);
    j["samples"][topic] = j["samples"].value(topic, 0) + 1;
  }
  void episode(const std::string& id) {
    if (id.empty()) return;
    std::lock_guard l(m);
    if (episodes.insert(id).second) j["episodes"].push_back(id);
  }
};

/// Counts remote participants discovered, and authenticated or refused by this one's security.
class Remotes : public fdds::DomainParticipantListener {
 public:
  explicit Remotes(Report& r) : r_(r) {}
  void on_participant_discovery(fdds::DomainParticipant*, eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) override {
    if (info.status == eprosima::fastrtps::rtps::ParticipantDiscoveryInfo::DISCOVERED_PARTICIPANT) bump("discovered");
  }
  void onParticipantAuthentication(fdds::DomainParticipant*,
                                   eprosima::fastrtps::rtps::ParticipantAuthenticationInfo&& info) override {
    bump(info.status == eprosima::fastrtps::rtps::ParticipantAuthenticationInfo::AUTHORIZED_PARTICIPANT ? "authorized"
                                                                                                        : "unauthorized");
  }

 private:
  void bump(const char* what) {
    std::lock_guard l(r_.m);
    r_.j["participants"][what] = r_.j["participants"].value(what, 0) + 1;
  }
  Report& r_;
};

template <class PubSub>
using ReaderPtr = std::unique_ptr<dh::dds::Reader<PubSub>>;
using AnyReader = std::variant<ReaderPtr<msg::ObservationPubSubType>, ReaderPtr<msg::ChannelStatusPubSubType>,
                               ReaderPtr<msg::EpisodeResultPubSubType>, ReaderPtr<msg::EpisodeRequestPubSubType>,
                               ReaderPtr<msg::CapabilityAnnouncePubSubType>, ReaderPtr<msg::VerdictPubSubType>,
                               ReaderPtr<msg::SeamEventPubSubType>, ReaderPtr<msg::ActionPubSubType>,
                               ReaderPtr<msg::CommandPubSubType>, ReaderPtr<msg::CommandStatusPubSubType>,
                               ReaderPtr<msg::LeasePubSubType>>;

AnyReader make_reader(dh::dds::Participant& p, const std::string& t, Report& r) {
  auto count = [&r, t](const std::string& episode) {
    r.sample(t);
    r.episode(episode);
  };
  if (t == topics::kObservation)
    return std::make_unique<dh::dds::Reader<msg::ObservationPubSubType>>(p, t, dh::dds::Qos::Observation,
        dh::dds::Reader<msg::ObservationPubSubType>::Callbacks{[&r, count](const msg::Observation& o, const auto&) {
          count(o.episode_id());
          std::lock_guard l(r.m);
          auto& s = r.j["steps"][o.episode_id()];
          s = std::max<std::uint32_t>(s.is_number() ? s.get<std::uint32_t>() : 0, o.step());
        }, {}, {}});
  if (t == topics::kChannelStatus)
    return std::make_unique<dh::dds::Reader<msg::ChannelStatusPubSubType>>(p, t, dh::dds::Qos::ChannelStatus,
        dh::dds::Reader<msg::ChannelStatusPubSubType>::Callbacks{[&r, count](const msg::ChannelStatus& s, const auto&) {
          count(s.episode_id());
          r.episode(s.last_episode_id());
        }, {}, {}});
  if (t == topics::kEpisodeResult)
    return std::make_unique<dh::dds::Reader<msg::EpisodeResultPubSubType>>(p, t, dh::dds::Qos::Episode,
        dh::dds::Reader<msg::EpisodeResultPubSubType>::Callbacks{
            [count](const msg::EpisodeResult& m, const auto&) { count(m.episode_id()); }, {}, {}});
  if (t == topics::kEpisodeRequest)
    return std::make_unique<dh::dds::Reader<msg::EpisodeRequestPubSubType>>(p, t, dh::dds::Qos::Episode,
        dh::dds::Reader<msg::EpisodeRequestPubSubType>::Callbacks{
            [count](const msg::EpisodeRequest& m, const auto&) { count(m.episode_id()); }, {}, {}});
  if (t == topics::kAnnounce)
    return std::make_unique<dh::dds::Reader<msg::CapabilityAnnouncePubSubType>>(p, t, dh::dds::Qos::Announce,
        dh::dds::Reader<msg::CapabilityAnnouncePubSubType>::Callbacks{[&r, t](const msg::CapabilityAnnounce& a, const auto&) {
          r.sample(t);
          std::lock_guard l(r.m);
          if (r.capabilities.insert(a.capability()).second) r.j["capabilities"].push_back(a.capability());
        }, {}, {}});
  if (t == topics::kVerdict)
    return std::make_unique<dh::dds::Reader<msg::VerdictPubSubType>>(p, t, dh::dds::Qos::Verdict,
        dh::dds::Reader<msg::VerdictPubSubType>::Callbacks{
            [count](const msg::Verdict& m, const auto&) { count(m.episode_id()); }, {}, {}});
  if (t == topics::kSeamEvent)
    return std::make_unique<dh::dds::Reader<msg::SeamEventPubSubType>>(p, t, dh::dds::Qos::Status,
        dh::dds::Reader<msg::SeamEventPubSubType>::Callbacks{[&r, count](const msg::SeamEvent& e, const auto&) {
          count(e.episode_id());
          std::lock_guard l(r.m);
          if (r.seam_commands.insert(e.command_id()).second) r.j["seam_commands"].push_back(e.command_id());
        }, {}, {}});
  if (t == topics::kAction)
    return std::make_unique<dh::dds::Reader<msg::ActionPubSubType>>(p, t, dh::dds::Qos::Action,
        dh::dds::Reader<msg::ActionPubSubType>::Callbacks{
            [count](const msg::Action& m, const auto&) { count(m.episode_id()); }, {}, {}});
  if (t == topics::kCommand)
    return std::make_unique<dh::dds::Reader<msg::CommandPubSubType>>(p, t, dh::dds::Qos::Command,
        dh::dds::Reader<msg::CommandPubSubType>::Callbacks{
            [count](const msg::Command& m, const auto&) { count(m.episode_id()); }, {}, {}});
  if (t == topics::kCommandStatus)
    return std::make_unique<dh::dds::Reader<msg::CommandStatusPubSubType>>(p, t, dh::dds::Qos::Status,
        dh::dds::Reader<msg::CommandStatusPubSubType>::Callbacks{
            [count](const msg::CommandStatus& m, const auto&) { count(m.episode_id()); }, {}, {}});
  if (t == topics::kLease)
    return std::make_unique<dh::dds::Reader<msg::LeasePubSubType>>(p, t, dh::dds::Qos::Lease,
        dh::dds::Reader<msg::LeasePubSubType>::Callbacks{
            [count](const msg::Lease& m, const auto&) { count(m.episode_id()); }, {}, {}});
  throw std::invalid_argument("sec_probe cannot read topic " + t);
}

/// A writer of any topic the probe may write, created only to see whether access control allows it.
struct AnyWriter {
  std::function<std::size_t()> matched;
  std::shared_ptr<void> keep;
};

template <class PubSub>
AnyWriter hold(std::shared_ptr<dh::dds::Writer<PubSub>> w) {
  return {[w] { return w->matched(); }, w};
}

AnyWriter make_writer(dh::dds::Participant& p, const std::string& t) {
  if (t == topics::kCommandStatus)
    return hold(std::make_shared<dh::dds::Writer<msg::CommandStatusPubSubType>>(p, t, dh::dds::Qos::Status));
  if (t == topics::kAnnounce)
    return hold(std::make_shared<dh::dds::Writer<msg::CapabilityAnnouncePubSubType>>(p, t, dh::dds::Qos::Announce));
  if (t == topics::kLease) return hold(std::make_shared<dh::dds::Writer<msg::LeasePubSubType>>(p, t, dh::dds::Qos::Lease));
  if (t == topics::kCommand) return hold(std::make_shared<dh::dds::Writer<msg::CommandPubSubType>>(p, t, dh::dds::Qos::Command));
  if (t == topics::kObservation)
    return hold(std::make_shared<dh::dds::Writer<msg::ObservationPubSubType>>(p, t, dh::dds::Qos::Observation));
  if (t == topics::kAction) return hold(std::make_shared<dh::dds::Writer<msg::ActionPubSubType>>(p, t, dh::dds::Qos::Action));
  throw std::invalid_argument("sec_probe cannot write topic " + t);
}

void save(Report& r, const std::string& file, const std::shared_ptr<std::vector<std::string>>& errors,
          const std::shared_ptr<std::mutex>& em) {
  std::string text;
  {
    std::lock_guard l(r.m);
    std::lock_guard le(*em);
    r.j["fastdds_errors"] = *errors;
    text = r.j.dump();
  }
  const std::string tmp = file + ".tmp";
  {
    std::ofstream out(tmp);
    out << text << "\n";
  }
  std::filesystem::rename(tmp, file);
}

}  // namespace

int main(int argc, char** argv) {
  std::string status_file, request_id, act_command, act_episode;
  double seconds = 600;
  std::uint32_t channel = 0;
  std::vector<std::string> reads, writes;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--status") status_file = next();
    else if (a == "--seconds") seconds = std::stod(next());
    else if (a == "--read") reads.push_back(next());
    else if (a == "--write") writes.push_back(next());
    else if (a == "--request") request_id = next();
    else if (a == "--channel") channel = static_cast<std::uint32_t>(std::stoul(next()));
    else if (a == "--act") act_command = next();
    else if (a == "--episode") act_episode = next();
    else {
      std::cerr << "sec_probe: unknown argument " << a << "\n";
      return 2;
    }
  }
  if (status_file.empty()) {
    std::cerr << "sec_probe: --status FILE is required\n";
    return 2;
  }
  install_shutdown_handlers();
  auto errors = std::make_shared<std::vector<std::string>>();
  auto em = std::make_shared<std::mutex>();
  fdds::Log::RegisterConsumer(std::make_unique<Collect>(errors, em));
  Report r;

  Remotes remotes(r);  // outlives the participant
  std::optional<dh::dds::Participant> p;
  try {
    p.emplace("sec_probe");
    // No entity statuses: a participant listener taking DATA_ON_READERS would starve the readers' own
    // on_data_available. Discovery and authentication callbacks come regardless of the mask.
    p->raw()->set_listener(&remotes, fdds::StatusMask::none());
    r.j["participant"] = "ok";
  } catch (const std::exception& e) {
    fdds::Log::Flush();
    r.j["participant"] = std::string("refused: ") + e.what();
    r.j["done"] = true;
    save(r, status_file, errors, em);
    std::cout << r.j.dump() << std::endl;
    return 3;
  }
  std::vector<AnyReader> readers;
  for (const auto& t : reads) {
    try {
      readers.push_back(make_reader(*p, t, r));
      r.j["readers"][t] = "ok";
      r.j["samples"][t] = 0;
    } catch (const std::runtime_error& e) {
      r.j["readers"][t] = std::string("refused: ") + e.what();
    }
  }
  std::map<std::string, AnyWriter> writers;
  auto try_writer = [&](const std::string& t) {
    if (writers.count(t)) return;
    try {
      writers[t] = make_writer(*p, t);
      r.j["writers"][t] = "ok";
    } catch (const std::runtime_error& e) {
      r.j["writers"][t] = std::string("refused: ") + e.what();
    }
  };
  for (const auto& t : writes) try_writer(t);
  std::optional<dh::dds::Writer<msg::EpisodeRequestPubSubType>> request;
  if (!request_id.empty()) {
    try {
      request.emplace(*p, topics::kEpisodeRequest, dh::dds::Qos::Episode);
      r.j["writers"][topics::kEpisodeRequest] = "ok";
    } catch (const std::runtime_error& e) {
      r.j["writers"][topics::kEpisodeRequest] = std::string("refused: ") + e.what();
    }
  }
  std::optional<dh::dds::Writer<msg::ActionPubSubType>> action;
  if (!act_command.empty()) {
    try {
      action.emplace(*p, topics::kAction, dh::dds::Qos::Action);
      r.j["writers"][topics::kAction] = "ok";
    } catch (const std::runtime_error& e) {
      r.j["writers"][topics::kAction] = std::string("refused: ") + e.what();
    }
  }
  fdds::Log::Flush();

  const auto t0 = Clock::now();
  bool requested = false;
  std::uint32_t step = 0;
  auto next_save = t0;
  std::size_t actions_written = 0;
  while (!shutdown_requested() && Clock::now() - t0 < std::chrono::duration<double>(seconds)) {
    if (request && !requested) {
      msg::EpisodeRequest q;
      q.channel(channel);
      q.episode_id(request_id);
      q.suite("goal");
      q.task(8);
      q.seed(1);
      q.cell("goal");
      q.arm("full");
      q.instruction("put the bowl on the plate");
      q.budget_steps(300);
      requested = request->write(q);  // transient local: a reader matched later still gets it
    }
    if (action) {
      msg::Action a;
      a.channel(channel);
      a.episode_id(act_episode);
      a.command_id(act_command);
      a.step(step++);
      a.a({0, 0, 0.5, 0, 0, 0, -1});
      actions_written += action->write(a);
    }
    if (Clock::now() >= next_save) {
      {
        std::lock_guard l(r.m);
        // The most remote readers each writer has matched so far.
        auto note = [&](const std::string& t, std::size_t n) {
          r.j["matched"][t] = std::max<std::size_t>(r.j["matched"].value(t, std::size_t{0}), n);
        };
        for (auto& [t, w] : writers) note(t, w.matched());
        if (request) note(topics::kEpisodeRequest, request->matched());
        if (action) note(topics::kAction, action->matched());
        r.j["actions_written"] = actions_written;
      }
      save(r, status_file, errors, em);
      next_save = Clock::now() + std::chrono::milliseconds(200);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  fdds::Log::Flush();
  p->raw()->set_listener(nullptr);
  {
    std::lock_guard l(r.m);
    r.j["done"] = true;
  }
  save(r, status_file, errors, em);
  std::cout << r.j.dump() << std::endl;
  return 0;
}
