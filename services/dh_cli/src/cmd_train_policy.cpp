// dh train-policy: demonstrations by the analytic capabilities (the whole stack in process, full arm),
// then behaviour cloning of the embedded policy, frozen to a checksummed weight file with its loss curve.
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <random>

#include "commands.hpp"
#include "dh/campaign/plan.hpp"
#include "dh/common/config.hpp"
#include "dh/common/paths.hpp"
#include "dh/common/suite.hpp"
#include "dh/inproc/stack.hpp"
#include "dh/policy/demo_file.hpp"
#include "dh/policy/train.hpp"

namespace dh::cli {

namespace {

struct DemoPlan {
  std::vector<std::pair<std::string, std::vector<unsigned>>> suites;  ///< suite -> seeds
  double noisy_share = 0, position_noise = 0, rotation_noise = 0;
};

DemoPlan demo_plan(const ConfigNode& d) {
  DemoPlan p;
  for (const auto& suite : d.keys()) {
    const ConfigNode s = d.child(suite);
    if (!s.has("seeds")) continue;  // the scalar keys below
    auto seeds = campaign::parse_numbers(s.get<std::string>("seeds"), "demonstrations." + suite + ".seeds");
    for (unsigned seed : seeds)
      if (seed < 1000 || seed >= 1000000)
        s.fail("seeds", "seed " + std::to_string(seed) +
                            " lies in an evaluation range (1-999, >= 1000000); demonstrations use seeds 1000-999999");
    p.suites.emplace_back(suite, std::move(seeds));
  }
  p.noisy_share = d.get<double>("noisy_share");
  p.position_noise = d.get<double>("position_noise");
  p.rotation_noise = d.get<double>("rotation_noise");
  return p;
}

std::vector<policy::Demo> collect(const DemoPlan& plan, const ConfigNode& demo_node, std::uint64_t seed,
                                  const std::filesystem::path& folder, nlohmann::json& facts) {
  // The full arm in process; only episodes whose verdict latched are kept.
  const auto t0 = std::chrono::steady_clock::now();
  const auto suites = load_suites(paths::config_dir());
  inproc::Stack stack(paths::config_dir());
  std::vector<policy::Demo> demos;
  std::mt19937_64 noise_rng(seed);
  std::normal_distribution<double> gauss(0, 1);
  std::uniform_real_distribution<double> unit(0, 1);
  unsigned episodes = 0, kept = 0, noisy = 0;
  for (const auto& [suite_name, seeds] : plan.suites) {
    const auto it = suites.find(suite_name);
    if (it == suites.end()) demo_node.fail(suite_name, "no suite '" + suite_name + "' (see dh tasks)");
    for (const auto& [id, task] : it->second.tasks)
      for (unsigned s : seeds) {
        policy::Demo d;
        d.key = suite_name + "/" + std::to_string(task.id) + "/" + std::to_string(s);
        d.instruction = task.instruction;
        const bool with_noise = unit(noise_rng) < plan.noisy_share;
        inproc::StepTap tap;
        tap.on_action = [&](const Observation& obs, const std::string&, const std::array<double, 7>& action) {
          if (d.entities.empty()) d.entities = policy::entity_names(obs);
          d.steps.push_back(policy::record(obs, d.actions.empty() ? -1.0 : d.actions.back()[6]));
          d.actions.push_back(action);
        };
        if (with_noise)
          tap.perturb = [&](std::array<double, 7>& action) {
            for (int i = 0; i < 3; ++i) action[i] += plan.position_noise * gauss(noise_rng);
            for (int i = 3; i < 6; ++i) action[i] += plan.rotation_noise * gauss(noise_rng);
          };
        const auto evidence = folder / "demos" / (suite_name + "_" + std::to_string(task.id) + "_" + std::to_string(s) + ".jsonl");
        const auto r = stack.run(task, s, "full", evidence, tap);
        ++episodes;
        if (r.success && !d.steps.empty()) {
          ++kept;
          noisy += with_noise;
          demos.push_back(std::move(d));
        }
      }
    std::printf("demonstrations %-5s %u of %u episodes kept so far\n", suite_name.c_str(), kept, episodes);
    std::fflush(stdout);
  }
  const double collect_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("demonstrations: %u of %u episodes succeeded (%u with action noise), %.1f s\n", kept, episodes, noisy,
              collect_s);
  facts = {{"episodes", episodes}, {"kept", kept}, {"noisy_kept", noisy}, {"collect_seconds", collect_s}};
  return demos;
}

}  // namespace

int cmd_train_policy(const TrainPolicyArgs& a) {
  const auto config_file = a.config.empty() ? paths::config_dir() / "policy.yaml" : std::filesystem::path(a.config);
  const ConfigNode root = ConfigNode::load_file(config_file);
  const DemoPlan plan = demo_plan(root.child("demonstrations"));
  policy::TrainConfig tc;
  tc.hidden = root.child("model").get<std::vector<int>>("hidden");
  tc.chunk = root.child("model").get<int>("chunk");
  const ConfigNode t = root.child("training");
  tc.seed = a.seed ? *a.seed : t.get<std::uint64_t>("seed");
  tc.epochs = a.epochs ? static_cast<int>(*a.epochs) : t.get<int>("epochs");
  tc.batch = t.get<int>("batch");
  tc.learning_rate = static_cast<float>(t.get<double>("learning_rate"));
  tc.learning_rate_final = static_cast<float>(t.get<double>("learning_rate_final"));
  tc.validation_share = t.get<double>("validation_share");
  const auto out = a.out.empty() ? paths::runs_dir() / root.get<std::string>("output") : std::filesystem::path(a.out);
  const auto folder = out.parent_path().empty() ? std::filesystem::path(".") : out.parent_path();

  std::vector<policy::Demo> demos;
  nlohmann::json demo_facts;
  const auto demo_file = folder / "demos.bin";
  if (a.reuse_demos) {
    demos = policy::load_demos(demo_file);
    demo_facts = {{"reused", demo_file.filename().string()}};
    std::printf("demonstrations: %zu read from %s\n", demos.size(), demo_file.string().c_str());
  } else {
    demos = collect(plan, root.child("demonstrations"), tc.seed, folder, demo_facts);
    if (demos.empty()) throw std::runtime_error("no demonstration succeeded: nothing to train on");
    policy::save_demos(demos, demo_file);
  }
  for (const auto& extra : a.add_demos) {
    auto more = policy::load_demos(extra);
    std::printf("demonstrations: %zu more read from %s\n", more.size(), extra.c_str());
    demos.insert(demos.end(), std::make_move_iterator(more.begin()), std::make_move_iterator(more.end()));
    demo_facts["added"].push_back(std::filesystem::path(extra).filename().string());
  }
  std::size_t steps = 0;
  for (const auto& d : demos) steps += d.steps.size();
  demo_facts["demonstrations"] = demos.size();
  demo_facts["steps"] = steps;

  std::filesystem::create_directories(folder);
  const auto curve_file = folder / "loss.csv";
  std::ofstream curve(curve_file, std::ios::trunc);
  curve << "epoch,train_mse,validation_mse\n";
  const auto t1 = std::chrono::steady_clock::now();
  policy::TrainResult r = policy::train_policy(demos, tc, [&](const policy::EpochLoss& e) {
    curve << e.epoch << "," << e.train << "," << e.validation << "\n" << std::flush;
    std::printf("epoch %3d  train %.5f  validation %.5f\n", e.epoch, e.train, e.validation);
    std::fflush(stdout);
  });
  const double train_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  r.model.training["demonstrations"] = demo_facts;
  r.model.training["config"] = config_file.filename().string();
  policy::save_policy(r.model, out);
  nlohmann::json manifest{{"weights", out.filename().string()},
                          {"version", r.model.version()},
                          {"sha256", r.model.checksum},
                          {"training", r.model.training},
                          {"train_seconds", train_s},
                          {"loss_curve", curve_file.filename().string()}};
  std::ofstream(folder / "train.json", std::ios::trunc) << manifest.dump(2) << "\n";
  std::printf("policy %s written to %s (sha256 %s); %zu training samples, %.1f s\n", r.model.version().c_str(),
              out.string().c_str(), r.model.checksum.c_str(), r.train_samples, train_s);
  return 0;
}

}  // namespace dh::cli
