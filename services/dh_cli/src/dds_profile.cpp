#include "dh/cli/dds_profile.hpp"

#include <fstream>
#include <stdexcept>

namespace dh::cli {

namespace {

std::string discovery_xml(const LaunchFile& launch) {
  // A dead peer is dropped after 3 s instead of the default 20 s (as deploy/dds/loopback.xml).
  const std::string leases =
      "            <leaseDuration><sec>3</sec></leaseDuration>\n"
      "            <leaseAnnouncement><sec>1</sec></leaseAnnouncement>\n";
  if (launch.discovery == Discovery::Multicast) return leases;
  const std::string& address = launch.host(launch.server_host).address;
  return "            <discoveryProtocol>CLIENT</discoveryProtocol>\n"
         "            <discoveryServersList>\n"
         "              <RemoteServer prefix=\"" + std::string(kDiscoveryServerPrefix) + "\">\n"
         "                <metatrafficUnicastLocatorList>\n"
         "                  <locator><udpv4><address>" + address + "</address><port>" +
         std::to_string(launch.server_port) + "</port></udpv4></locator>\n"
         "                </metatrafficUnicastLocatorList>\n"
         "              </RemoteServer>\n"
         "            </discoveryServersList>\n" +
         leases;
}

}  // namespace

std::string host_profile_xml(const LaunchFile& launch, const std::string& host) {
  const HostSpec& h = launch.host(host);
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<!-- Made by dh for host '" + h.name + "' of " + launch.file.filename().string() +
         ": UDPv4 only on " + h.address + ", shared memory between this host's processes, discovery by " +
         (launch.discovery == Discovery::Multicast ? std::string("multicast on that link")
                                                   : "the discovery server on host '" + launch.server_host + "'") +
         ". -->\n"
         "<dds xmlns=\"http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles\">\n"
         "  <profiles>\n"
         "    <transport_descriptors>\n"
         "      <transport_descriptor>\n"
         "        <transport_id>dh_udp_host</transport_id>\n"
         "        <type>UDPv4</type>\n"
         "        <interfaceWhiteList><address>" + h.address + "</address></interfaceWhiteList>\n"
         "      </transport_descriptor>\n"
         "      <transport_descriptor>\n"
         "        <transport_id>dh_shm</transport_id>\n"
         "        <type>SHM</type>\n"
         "      </transport_descriptor>\n"
         "    </transport_descriptors>\n"
         "    <participant profile_name=\"dh_participant\">\n"
         "      <rtps>\n"
         "        <useBuiltinTransports>false</useBuiltinTransports>\n"
         "        <userTransports>\n"
         "          <transport_id>dh_shm</transport_id>\n"
         "          <transport_id>dh_udp_host</transport_id>\n"
         "        </userTransports>\n"
         "        <builtin>\n"
         "          <discovery_config>\n" +
         discovery_xml(launch) +
         "          </discovery_config>\n"
         "        </builtin>\n"
         "      </rtps>\n"
         "    </participant>\n"
         "  </profiles>\n"
         "</dds>\n";
}

std::filesystem::path write_host_profile(const LaunchFile& launch, const std::string& host,
                                         const std::filesystem::path& dir) {
  const std::string xml = host_profile_xml(launch, host);
  std::filesystem::create_directories(dir);
  const auto path = dir / (launch.file.stem().string() + "-" + host + ".xml");
  std::ofstream out(path);
  out << xml;
  if (!out.flush()) throw std::runtime_error("cannot write the DDS profile " + path.string());
  return path;
}

}  // namespace dh::cli
