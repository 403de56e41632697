// Launch files with hosts, and the DDS profile each host gets: parsed, refused with reasons, and loaded
// by Fast DDS itself.
#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <signal.h>
#include <unistd.h>

#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <filesystem>
#include <fstream>
#include <functional>
#include <thread>

#include "dh/cli/dds_profile.hpp"
#include "dh/cli/launcher.hpp"
#include "dh/common/config.hpp"
#include "dh/common/paths.hpp"

namespace dh::cli {
namespace {

namespace fs = std::filesystem;
namespace fdds = eprosima::fastdds::dds;

struct LaunchFileTest : ::testing::Test {
  fs::path dir;
  void SetUp() override {
    dir = fs::temp_directory_path() / ("dh_test_launch_" + std::to_string(::getpid()) + "_" +
                                       ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }
  fs::path write(const std::string& yaml) const {
    const auto p = dir / "launch.yaml";
    std::ofstream(p) << yaml;
    return p;
  }
};

const std::string kThreeHosts = R"(
hosts:
  - {name: control, address: 10.1.0.1}
  - {name: sim1, address: 10.1.0.2}
services:
  - {name: governor, host: control, exec: governor}
  - {name: sim_worker, host: sim1, exec: sim_worker, args: [--channels, "3"]}
)";

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(no error)";
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

void replace_all(std::string& text, const std::string& from, const std::string& to) {
  for (auto i = text.find(from); i != std::string::npos; i = text.find(from, i + to.size())) text.replace(i, from.size(), to);
}

/// Loads `xml` into Fast DDS under profile and transport names of its own (Fast DDS keeps every name it
/// loaded in the process) and returns the participant QoS it defines.
fdds::DomainParticipantQos load_in_fast_dds(std::string xml, const fs::path& file, const std::string& name) {
  replace_all(xml, "dh_participant", name);
  replace_all(xml, "dh_udp_host", name + "_udp");
  replace_all(xml, "dh_discovery_server", name);
  replace_all(xml, "dh_udp_server", name + "_udp");
  std::ofstream(file) << xml;
  auto* factory = fdds::DomainParticipantFactory::get_instance();
  EXPECT_EQ(factory->load_XML_profiles_file(file.string()), ReturnCode_t::RETCODE_OK);
  fdds::DomainParticipantQos qos;
  EXPECT_EQ(factory->get_participant_qos_from_profile(name, qos), ReturnCode_t::RETCODE_OK);
  return qos;
}

TEST_F(LaunchFileTest, TheShippedMultiHostFileGivesEachHostItsShare) {
  const LaunchFile l = load_launch(paths::home() / "deploy" / "multihost.yaml");
  ASSERT_EQ(l.hosts.size(), 3u);
  EXPECT_EQ(l.discovery, Discovery::Multicast);
  const auto sim1 = l.services_on("sim1", dir), sim2 = l.services_on("sim2", dir), control = l.services_on("control", dir);
  ASSERT_EQ(sim1.size(), 1u);
  ASSERT_EQ(sim2.size(), 1u);
  EXPECT_EQ(sim1[0].exec, "sim_worker");
  EXPECT_EQ(sim2[0].args, (std::vector<std::string>{"--channels", "11", "--first-channel", "11", "--name", "sim2"}));
  EXPECT_EQ(control.size(), l.services.size() - 2);
  for (const auto& s : control) EXPECT_NE(s.exec, "sim_worker");
  EXPECT_TRUE(contains(error_of([&] { l.services_on("sim3", dir); }), "no host 'sim3' (hosts: control, sim1, sim2)"));
}

TEST_F(LaunchFileTest, TheShippedCellFileDrivesTheArmThroughTheAdapterAndLooksAtTheParts) {
  const LaunchFile l = load_launch(paths::home() / "deploy" / "cell" / "cell.yaml");
  const auto robot = l.services_on("robot", dir), control = l.services_on("control", dir);
  ASSERT_EQ(robot.size(), 1u);
  EXPECT_EQ(robot[0].exec, "robot_adapter");
  for (const auto& s : l.services) EXPECT_NE(s.exec, "sim_worker") << s.name << ": nothing simulated on a cell";
  const auto perception = std::find_if(control.begin(), control.end(), [](const auto& s) { return s.exec == "perception"; });
  ASSERT_NE(perception, control.end());
  const auto& a = perception->args;
  const auto parts = std::find(a.begin(), a.end(), "--parts-camera");
  ASSERT_NE(parts, a.end());
  ASSERT_NE(parts + 1, a.end());
  // Each camera perception asks has a source on the camera host.
  std::set<std::string> played;
  for (const auto& s : l.services_on("camera", dir))
    if (const auto c = std::find(s.args.begin(), s.args.end(), "--camera"); c != s.args.end() && c + 1 != s.args.end())
      played.insert(*(c + 1));
  EXPECT_EQ(played, (std::set<std::string>{"workcell", *(parts + 1)}));
}

TEST_F(LaunchFileTest, ADiscoveryServerIsStartedFirstOnItsHost) {
  const LaunchFile l = load_launch(write(kThreeHosts + "discovery: server\ndiscovery_server: {host: control, port: 11900}\n"));
  EXPECT_EQ(l.discovery, Discovery::Server);
  const auto control = l.services_on("control", dir);
  ASSERT_EQ(control.size(), 2u);
  EXPECT_EQ(control[0].exec, "fast-discovery-server");
  EXPECT_TRUE(control[0].from_path);
  EXPECT_EQ(control[0].args, (std::vector<std::string>{"-x", (dir / "launch-discovery_server.xml").string()}));
  EXPECT_EQ(l.services_on("sim1", dir).size(), 1u) << "only the server's host runs it";
  // Its profile: a SERVER with id 0's prefix, listening on its host's address and port only.
  const auto qos = load_in_fast_dds(server_profile_xml(l), dir / "s.xml", "dh_test_server");
  const auto& d = qos.wire_protocol().builtin.discovery_config;
  EXPECT_EQ(d.discoveryProtocol, eprosima::fastrtps::rtps::DiscoveryProtocol_t::SERVER);
  std::ostringstream prefix;
  prefix << qos.wire_protocol().prefix;
  EXPECT_EQ(prefix.str(), kDiscoveryServerPrefix);
  const auto& meta = qos.wire_protocol().builtin.metatrafficUnicastLocatorList;
  ASSERT_EQ(meta.size(), 1u);
  EXPECT_EQ(meta.begin()->port, 11900u);
  EXPECT_FALSE(qos.transport().use_builtin_transports);
}

TEST_F(LaunchFileTest, BadHostsAreRefusedNamingTheKey) {
  EXPECT_TRUE(contains(error_of([&] { load_launch(write("hosts:\n  - {name: a, address: 10.1.0.300}\nservices:\n  - {name: g, host: a, exec: governor}\n")); }),
                       "'10.1.0.300' is not an IPv4 address"));
  EXPECT_TRUE(contains(error_of([&] { load_launch(write("hosts:\n  - {name: a, address: 10.1.0.1}\n  - {name: b, address: 10.1.0.1}\nservices:\n  - {name: g, host: a, exec: governor}\n")); }),
                       "10.1.0.1 is given to two hosts"));
  EXPECT_TRUE(contains(error_of([&] { load_launch(write("hosts:\n  - {name: a, address: 10.1.0.1}\nservices:\n  - {name: g, exec: governor}\n")); }),
                       "says which host runs each service"));
  EXPECT_TRUE(contains(error_of([&] { load_launch(write("hosts:\n  - {name: a, address: 10.1.0.1}\nservices:\n  - {name: g, host: z, exec: governor}\n")); }),
                       "'z' is not one of the hosts"));
  EXPECT_TRUE(contains(error_of([&] { load_launch(write(kThreeHosts + "discovery: broadcast\n")); }),
                       "'broadcast' is not multicast or server"));
  EXPECT_TRUE(contains(error_of([&] { load_launch(write(kThreeHosts + "discovery: server\ndiscovery_server: {host: nas}\n")); }),
                       "'nas' is not one of the hosts"));
  EXPECT_TRUE(contains(error_of([&] { load_launch(write("services:\n  - {name: g, host: a, exec: governor}\n")); }),
                       "this file has no hosts: section"));
  EXPECT_TRUE(contains(error_of([&] { load_launch_file(write(kThreeHosts)); }), "--host NAME"));
}

TEST_F(LaunchFileTest, AHostProfilePinsUdpToItsAddressAndFastDdsLoadsIt) {
  const LaunchFile l = load_launch(write(kThreeHosts));
  const std::string xml = host_profile_xml(l, "sim1");
  EXPECT_TRUE(contains(xml, "<interfaceWhiteList><address>10.1.0.2</address></interfaceWhiteList>"));
  EXPECT_FALSE(contains(xml, "10.1.0.1")) << "a multicast profile names no other host";
  EXPECT_FALSE(contains(xml, "CLIENT"));
  const auto qos = load_in_fast_dds(xml, dir / "p.xml", "dh_test_multicast");
  EXPECT_FALSE(qos.transport().use_builtin_transports);
  EXPECT_EQ(qos.transport().user_transports.size(), 1u) << "UDPv4 only, no shared memory";
  EXPECT_EQ(qos.wire_protocol().builtin.discovery_config.discoveryProtocol,
            eprosima::fastrtps::rtps::DiscoveryProtocol_t::SIMPLE);
  EXPECT_EQ(qos.wire_protocol().builtin.discovery_config.leaseDuration.seconds, 3);
}

TEST_F(LaunchFileTest, UnderADiscoveryServerEveryHostIsItsClient) {
  const LaunchFile l = load_launch(write(kThreeHosts + "discovery: server\ndiscovery_server: {host: control, port: 11900}\n"));
  const auto path = write_host_profile(l, "sim1", dir / "dds");
  EXPECT_EQ(path, dir / "dds" / "launch-sim1.xml");
  std::ifstream in(path);
  const std::string xml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto qos = load_in_fast_dds(xml, dir / "p.xml", "dh_test_client");
  const auto& d = qos.wire_protocol().builtin.discovery_config;
  EXPECT_EQ(d.discoveryProtocol, eprosima::fastrtps::rtps::DiscoveryProtocol_t::CLIENT);
  ASSERT_EQ(d.m_DiscoveryServers.size(), 1u);
  const auto& server = d.m_DiscoveryServers.front();
  std::ostringstream prefix;
  prefix << server.guidPrefix;
  EXPECT_EQ(prefix.str(), "44.53.00.5f.45.50.52.4f.53.49.4d.41");
  ASSERT_EQ(server.metatrafficUnicastLocatorList.size(), 1u);
  const auto& loc = *server.metatrafficUnicastLocatorList.begin();
  EXPECT_EQ(loc.port, 11900u);
  EXPECT_EQ(eprosima::fastrtps::rtps::IPLocator::ip_to_string(loc), "10.1.0.1");
}

TEST_F(LaunchFileTest, UnderSecurityEachServiceGetsItsOwnProfileOrTheFileIsRefused) {
  const std::string yaml = "security: " + (dir / "keys").string() +
                           "\nservices:\n  - {name: governor, exec: governor}\n  - {name: planner, exec: planner}\n";
  EXPECT_TRUE(contains(error_of([&] { load_launch(write(yaml)); }),
                       "no secured profile " + (dir / "keys" / "governor.xml").string() + " for service 'governor'"));
  fs::create_directories(dir / "keys");
  std::ofstream(dir / "keys" / "governor.xml") << "<dds/>";
  std::ofstream(dir / "keys" / "planner.xml") << "<dds/>";
  const LaunchFile l = load_launch(write(yaml));
  EXPECT_EQ(l.services[0].env.at("DH_DDS_PROFILE"), (dir / "keys" / "governor.xml").string());
  EXPECT_EQ(l.services[1].env.at("DH_DDS_PROFILE"), (dir / "keys" / "planner.xml").string());
}

TEST_F(LaunchFileTest, AServiceSeesItsOwnVariablesOverTheLaunchersEnvironment) {
  setenv("DH_TEST_LAUNCH_VAR", "launcher", 1);
  ServiceSpec sh{"sh", "sh", {"-c", "echo $DH_TEST_LAUNCH_VAR $DH_TEST_OTHER > " + (dir / "out.txt").string()}};
  sh.from_path = true;
  sh.env["DH_TEST_LAUNCH_VAR"] = "service";
  setenv("DH_TEST_OTHER", "kept", 1);
  {
    Deployment d({sh}, dir, dir / "logs");
    for (int i = 0; i < 200 && d.exited().empty(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::ifstream in(dir / "out.txt");
  std::string a, b;
  in >> a >> b;
  EXPECT_EQ(a, "service");
  EXPECT_EQ(b, "kept");
}

TEST_F(LaunchFileTest, AnExitedServiceCanBeStartedAgain) {
  ServiceSpec sleeper{"sleeper", "sleep", {"30"}};
  sleeper.from_path = true;
  Deployment d({sleeper}, dir, dir / "logs");
  const auto before = d.running();
  ASSERT_EQ(before.size(), 1u);
  EXPECT_FALSE(d.restart("sleeper")) << "it is running";
  ASSERT_TRUE(d.signal("sleeper", SIGKILL));
  std::vector<std::string> gone;
  for (int i = 0; i < 200 && gone.empty(); ++i) {
    gone = d.exited();
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(gone, std::vector<std::string>{"sleeper"});
  EXPECT_TRUE(d.running().empty());
  EXPECT_TRUE(d.restart("sleeper"));
  EXPECT_FALSE(d.restart("nobody"));
  const auto after = d.running();
  ASSERT_EQ(after.size(), 1u);
  EXPECT_NE(after[0].second, before[0].second) << "a new process";
}

}  // namespace
}  // namespace dh::cli
