// dh view: the live view's DDS shell. Its panes read only DDS: every simulator worker's channel
// announcements (rt/dh/sim/channel), every governor's episode state (rt/dh/evidence) and every campaign's
// progress (rt/dh/campaign/progress), on any host of the domain. The episode page reads an evidence file
// of this host, by path, when it lies under the runs folder or an --evidence-root.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>
#include <thread>
#include <stdlib.h>
#include <unistd.h>

#include "commands.hpp"
#include "dh/common/dds.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/shutdown.hpp"
#include "dh/common/topics.hpp"
#include "dh/film/film.hpp"
#include "dh/msg/episodePubSubTypes.h"
#include "dh/view/board.hpp"
#include "dh/view/server.hpp"
#include "dh/view/timeline.hpp"
#include "worker_writers.hpp"

namespace dh::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

view::Response error(unsigned status, const std::string& what) { return {status, "application/json", json{{"error", what}}.dump()}; }

// The evidence file a page asks for, when it may be read: a .jsonl under one of `roots` (canonical).
std::optional<fs::path> allowed(const std::string& asked, const std::vector<fs::path>& roots, std::string& why) {
  if (asked.empty()) {
    why = "no evidence file was named (?evidence=PATH)";
    return std::nullopt;
  }
  std::error_code ec;
  const fs::path p = fs::weakly_canonical(fs::path(asked), ec);
  if (ec || p.extension() != ".jsonl") {
    why = asked + ": not an evidence file (<episode>.jsonl)";
    return std::nullopt;
  }
  for (const auto& root : roots) {
    const auto rel = p.lexically_relative(root);
    if (!rel.empty() && *rel.begin() != "..") return p;
  }
  why = asked + ": outside the folders this view serves (the runs folder; --evidence-root adds one)";
  return std::nullopt;
}

}  // namespace

int cmd_view(const ViewArgs& a) {
  // Made canonical once; every page's request is checked against them.
  std::vector<fs::path> roots;
  const auto add_root = [&](const fs::path& r) {
    std::error_code ec;
    if (auto c = fs::weakly_canonical(r, ec); !ec) roots.push_back(std::move(c));
  };
  add_root(paths::runs_dir());
  for (const auto& r : a.evidence_roots) add_root(r);
  const fs::path attribution = paths::config_dir() / "attribution.yaml";
  // The films made for episode pages: a folder of this process's own (mkdtemp: nobody else's files in it).
  std::string pattern = (fs::temp_directory_path() / "dh_view_XXXXXX").string();
  if (!::mkdtemp(pattern.data())) {
    std::cerr << "error: cannot make a folder for films under " << fs::temp_directory_path() << "\n";
    return 1;
  }
  const fs::path films = pattern;

  std::mutex m;
  view::Board board;
  WorkerWriters workers;
  dds::Participant participant("dh_view");
  using Info = eprosima::fastdds::dds::SampleInfo;
  dds::Reader<msg::ChannelStatusPubSubType> channels(
      participant, topics::kChannelStatus, dds::Qos::ChannelStatus,
      {[&](const msg::ChannelStatus& s, const Info& info) {
         std::lock_guard l(m);
         workers.saw(info.publication_handle, s.worker());
         board.on_channel({s.channel(), s.worker(), s.state() == msg::CHANNEL_RUNNING, s.episode_id()},
                          view::Clock::now());
       },
       [&](const eprosima::fastdds::dds::LivelinessChangedStatus& st) {
         std::lock_guard l(m);
         const auto change = workers.changed(st);
         if (!change) return;
         if (change->alive)
           board.on_worker_back(change->worker, view::Clock::now());
         else
           board.on_worker_lost(change->worker, view::Clock::now());
       },
       {}});
  dds::Reader<msg::EpisodeLivePubSubType> live(
      participant, topics::kEvidence, dds::Qos::Episode,
      {[&](const msg::EpisodeLive& e, const Info&) {
         std::lock_guard l(m);
         board.on_live({e.channel(), e.episode_id(), e.arm(), e.cell(), e.task(), e.seed(), e.step(), e.budget_steps(),
                        e.capability(), e.decision(), e.reason(), e.ended(), e.outcome(), e.evidence_path()},
                       view::Clock::now());
       },
       {}, {}});
  dds::Reader<msg::CampaignProgressPubSubType> progress(
      participant, topics::kCampaignProgress, dds::Qos::Episode,
      {[&](const msg::CampaignProgress& p, const Info&) {
         view::CampaignProgress c{p.campaign(), p.total(), p.done(), p.successes(), p.infrastructure(), p.reran(),
                                  p.rate_per_s(), p.eta_s(), p.finished(), {}};
         for (const auto& t : p.cells()) c.cells.push_back({t.arm(), t.cell(), t.successes(), t.episodes()});
         std::lock_guard l(m);
         board.on_progress(c, view::Clock::now());
       },
       {}, {}});

  view::Handlers handlers;
  handlers.snapshot = [&] {
    std::lock_guard l(m);
    return board.snapshot(view::Clock::now());
  };
  handlers.api = [&](const std::string& name, const std::map<std::string, std::string>& q) -> view::Response {
    std::string why;
    const auto asked = q.count("evidence") ? q.at("evidence") : std::string();
    if (name != "episode" && name != "film") return error(404, "no such API: /api/" + name);
    const auto file = allowed(asked, roots, why);
    if (!file) return error(403, why);
    try {
      if (name == "episode") return {200, "application/json", view::episode_timeline(*file, attribution).dump()};
      // A film is made once per file and kept while the view runs. Calls run side by side: each writes
      // its own file and renames it into place, so a reader never sees half a strip.
      const fs::path png = films / (std::to_string(std::hash<std::string>{}(file->string())) + ".png");
      if (!fs::exists(png)) {
        film::FilmOptions o;
        o.config_dir = paths::config_dir();
        o.strip = films / (png.stem().string() + "." +
                           std::to_string(std::hash<std::thread::id>{}(std::this_thread::get_id())) + ".png");
        o.allow_drift = true;  // an older build's episode is still worth seeing; the strip says it departs
        film::film(*file, o);
        fs::rename(o.strip, png);
      }
      std::ifstream in(png, std::ios::binary);
      std::stringstream body;
      body << in.rdbuf();
      return {200, "image/png", body.str()};
    } catch (const std::exception& e) {
      return error(422, e.what());
    }
  };
  view::ServerOptions o;
  o.bind = a.bind;
  o.port = a.port;
  o.token = a.token;
  o.web_dir = paths::home() / "services" / "view" / "web";
  std::unique_ptr<view::Server> server;
  try {
    server = std::make_unique<view::Server>(o, handlers);
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  }
  std::cerr << "dh view: http://" << a.bind << ":" << server->port() << "/" << (a.token.empty() ? "" : "?token=...")
            << "  (Ctrl-C stops it)\n";
  if (!a.port_file.empty()) std::ofstream(a.port_file) << server->port() << "\n";
  install_shutdown_handlers();
  while (!shutdown_requested()) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  server.reset();
  std::error_code ec;
  fs::remove_all(films, ec);
  return 0;
}

}  // namespace dh::cli
