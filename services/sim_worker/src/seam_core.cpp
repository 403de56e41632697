#include "dh/sim/seam_core.hpp"

#include "dh/common/build_info.hpp"

namespace dh::sim {

SeamCore::SeamCore(std::uint32_t channel, SeamSettings settings) : channel_(channel), settings_(settings) {}

const Ports& SeamCore::ports() {
  static const Ports p{
      in_port<port::EpisodeRequest>("reset the channel to suite/task/seed"),
      in_port<port::Lease>(
          "the governor's grant for the running command; its deadline says the writer went silent"),
      in_port<port::Action>("one 7-d action per step, lock-step"),
      in_port<port::EpisodeResult>("the channel goes idle"),
      out_port<port::Observation>("after the reset (step 0) and after every applied action"),
      out_port<port::Verdict>("every change of the task predicate"),
      out_port<port::SeamEvent>("refused actions and safety corrections, with reasons"),
  };
  return p;
}

SeamEffects SeamCore::start(SeamCell& cell, std::string episode_id, std::uint32_t budget_steps,
                            std::string predicate, SeamClock::time_point now,
                            const std::filesystem::path& steps_file) {
  const RecordableState* rec = cell.recordable();
  if (!steps_file.empty() && !rec)
    throw std::invalid_argument("a step log was asked for (" + steps_file.string() +
                                ") but this cell's state cannot be recorded; run it without one");
  begin(cell, std::move(episode_id), budget_steps, std::move(predicate), now);
  if (!steps_file.empty()) {
    const auto engine = rec->engine_version();
    log_ = std::make_unique<StepLogWriter>(
        steps_file,
        StepLogHeader{rec->model_hash(), engine, static_cast<std::uint32_t>(rec->digest().joints.size() / 2),
                      build_info().str()});
    states_ = std::make_unique<StateLogWriter>(std::filesystem::path(steps_file).replace_extension(".states"),
                                               StateLogHeader{rec->model_hash(), engine, rec->shape()});
    states_->append({0, {}, rec->physics_state()});
  }
  SeamEffects fx;
  observe(fx, nullptr);
  return fx;
}

SeamEffects SeamCore::resume(SeamCell& cell, std::string episode_id, std::uint32_t budget_steps,
                             std::string predicate, const StateRecord& from, SeamClock::time_point now) {
  RecordableState* rec = cell.recordable();
  if (!rec)
    throw std::invalid_argument("this cell's state cannot be restored: an episode cannot resume on it");
  begin(cell, std::move(episode_id), budget_steps, std::move(predicate), now);
  rec->restore(from.state);
  step_ = from.step;
  started_ = {from.command_id};
  predicate_ = cell.observe().goal_holds;
  SeamEffects fx;
  observe(fx, nullptr);
  return fx;
}

void SeamCore::begin(SeamCell& cell, std::string episode_id, std::uint32_t budget_steps,
                     std::string predicate, SeamClock::time_point now) {
  cell_ = &cell;
  episode_ = std::move(episode_id);
  predicate_text_ = std::move(predicate);
  budget_ = budget_steps;
  step_ = 0;
  lease_ = {};
  pending_.clear();
  predicate_ = false;
  goal_step_.reset();
  physics_s_ = 0;
  lease_at_ = last_sign_of_life_ = now;
  log_.reset();
  states_.reset();
  started_.clear();
  handed_over_.clear();
  stragglers_ = 0;
}

void SeamCore::end() {
  cell_ = nullptr;
  pending_.clear();
  lease_ = {};
  log_.reset();
  states_.reset();
}

SeamEffects SeamCore::on_lease(const LeaseGrant& l, SeamClock::time_point now) {
  if (!running() || l.episode_id != episode_) return {};
  // A command's first lease comes before any of its actions can apply (admission needs it): the state
  // now is the one the command starts from. Leases are rewritten, so only a new command id counts.
  std::optional<Observation> again;
  if (!l.revoked && started_.insert(l.command_id).second) {
    if (states_) states_->append({step_, l.command_id, cell_->recordable()->physics_state()});
    again = observation_;
  }
  // The governor has moved on from a command it revokes or whose lease it gives to another.
  if (l.revoked)
    handed_over_.insert(l.command_id);
  else {
    handed_over_.erase(l.command_id);
    if (lease_.known && lease_.command_id != l.command_id) handed_over_.insert(lease_.command_id);
  }
  std::erase_if(pending_, [&](const auto& p) {
    const bool straggler = handed_over_.count(p.first) > 0;
    stragglers_ += straggler;
    return straggler;
  });
  lease_ = {true, l.command_id, l.valid_until_step, l.budget_until_step, l.revoked, false};
  lease_at_ = last_sign_of_life_ = now;
  SeamEffects fx = admit(now);
  fx.again = std::move(again);
  return fx;
}

SeamEffects SeamCore::on_action(const ActionIn& a, SeamClock::time_point now) {
  SeamEffects fx;
  if (!running() || a.episode_id != episode_) {
    fx.events.push_back({a.step, a.command_id, SeamEventKind::RejectedCommand,
                         "action for episode '" + a.episode_id + "' which is not running on this channel",
                         a.episode_id});
    return fx;
  }
  // A straggler: the command's host answered a step before it heard that the governor moved on. Over
  // DDS whether one comes, and whether before or after the handover, is a race between topics, so it is
  // counted, not recorded; it can never apply.
  if (handed_over_.count(a.command_id)) {
    ++stragglers_;
    return fx;
  }
  std::optional<SeamEvent> superseded;
  auto it = pending_.find(a.command_id);
  if (it != pending_.end() && it->second.action.step != a.step)
    superseded = SeamEvent{it->second.action.step,
                           a.command_id,
                           SeamEventKind::RejectedStep,
                           "superseded by the same command's action for step " + std::to_string(a.step),
                           {}};
  // The same command answering the same step again (a re-send) keeps its place in the grace period.
  const auto since = it != pending_.end() && it->second.action.step == a.step ? it->second.since : now;
  pending_[a.command_id] = {a, since};
  fx = admit(now);
  if (superseded) fx.events.insert(fx.events.begin(), std::move(*superseded));
  return fx;
}

bool SeamCore::on_lease_silent(SeamClock::time_point now) {
  if (!running() || !lease_.known || lease_.revoked || lease_.writer_silent) return false;
  if (now - lease_at_ < settings_.lease_deadline) return false;
  lease_.writer_silent = true;
  return true;
}

SeamEffects SeamCore::on_tick(SeamClock::time_point now) {
  if (!running()) return {};
  if (now - last_sign_of_life_ >= settings_.abandon_after) {
    SeamEffects fx;
    ended_by_seam(fx,
                  "no lease, request or applied action for " +
                      std::to_string(
                          std::chrono::duration_cast<std::chrono::seconds>(settings_.abandon_after).count()) +
                      " s (governor gone?); episode abandoned at step " + std::to_string(step_));
    return fx;
  }
  return admit(now);
}

SeamEffects SeamCore::admit(SeamClock::time_point now) {
  SeamEffects fx;
  for (auto it = pending_.begin(); running() && it != pending_.end();) {
    const ActionIn& a = it->second.action;
    const auto r =
        admit_action(a.command_id, a.step, step_, budget_, lease_, now - it->second.since >= settings_.grace);
    if (r.decision == Admission::WaitForLease) {
      ++it;
      continue;
    }
    if (r.decision != Admission::Apply) {
      fx.events.push_back({a.step, a.command_id, seam_event_kind(r.decision), r.reason, {}});
      it = pending_.erase(it);
      continue;
    }
    const ActionIn applied = a;
    pending_.erase(it);
    const auto t0 = SeamClock::now();
    std::vector<StepEvent> corrections;
    try {
      corrections = cell_->step(applied.a);
    } catch (const std::exception& e) {
      // The cell cannot go on (MuJoCo's contact buffer overflowed, the controller stopped the arm): the
      // episode is lost, and the governor hears why from the seam's event.
      ended_by_seam(fx, "the cell failed at step " + std::to_string(step_) + ": " + e.what(),
                    applied.command_id);
      return fx;
    }
    physics_s_ += std::chrono::duration<double>(SeamClock::now() - t0).count();
    last_sign_of_life_ = now;
    for (const auto& e : corrections)
      fx.events.push_back({step_, applied.command_id, seam_event_kind(e.kind), e.reason, {}});
    ++step_;
    observe(fx, &applied);
    // What else waits is for the step just applied: refused as stale on the next pass.
    it = pending_.begin();
  }
  return fx;
}

void SeamCore::ended_by_seam(SeamEffects& fx, std::string why, std::string command_id) {
  fx.events.push_back({step_, std::move(command_id), SeamEventKind::Ended, why, {}});
  fx.ended = std::move(why);
  end();
}

void SeamCore::observe(SeamEffects& fx, const ActionIn* applied) {
  if (log_)
    log_->append({step_, applied ? applied->command_id : std::string(),
                  applied ? applied->a : std::array<double, 7>{}, cell_->recordable()->digest(),
                  applied ? applied->frames : 0});
  observation_ = cell_->observe();
  observation_.channel = channel_;
  observation_.episode_id = episode_;
  observation_.step = step_;
  observation_.budget_steps = budget_;
  if (observation_.goal_holds && !goal_step_) goal_step_ = step_;
  if (observation_.goal_holds != predicate_) {
    predicate_ = observation_.goal_holds;
    fx.verdict = VerdictChange{step_, predicate_text_, predicate_};
  }
  fx.observation = observation_;
  fx.to = applied ? applied->from : std::string();
}

}  // namespace dh::sim
