#include <sys/stat.h>

#include <cstdint>
#include <cstdlib>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>

#include <memory>
#include <sstream>

#include "tandem/dds/bus.hpp"

namespace tandem::dds {

namespace {

constexpr uint32_t kUdpReceiveBuffer = 4u << 20;  // [bytes] per UDP socket, requested (see Participant::Participant)
// A Discovery Server client's announcement period and lease [s] (see Participant::Participant).
constexpr int32_t kServerClientAnnouncementS = 5;
constexpr int32_t kServerClientLeaseS = 12;

// Fast DDS 2.9.1 matches a newly discovered secured participant's handshake endpoints through shared scratch
// proxies without a lock (SecurityManager::match_builtin_endpoints). Two participants discovered at once on two
// receive threads (multicast SPDP on one, unicast or shared-memory metatraffic on another) overwrite each other's
// proxy and that pair never authenticates (docs/security.md, "Start-up"). Every call into that code comes from
// the thread that received the SPDP or handshake message, so a secured participant takes all its discovery and
// handshake traffic on one UDP unicast port: one receive thread, and the race cannot happen. No multicast:
// it announces itself to the deployment's hosts (TANDEM_DDS_PEERS, set with the keys by runtime::use_security;
// 127.0.0.1 without it) on the well-known ports of participant ids 0-119.
void single_discovery_thread(fdds::DomainParticipantQos& qos, eprosima::fastdds::rtps::UDPv4TransportDescriptor& udp) {
  namespace rtps = eprosima::fastrtps::rtps;
  auto& builtin = qos.wire_protocol().builtin;
  rtps::Locator_t meta;  // any address, port from the participant id
  meta.kind = LOCATOR_KIND_UDPv4;
  builtin.metatrafficUnicastLocatorList.clear();
  builtin.metatrafficMulticastLocatorList.clear();
  builtin.metatrafficUnicastLocatorList.push_back(meta);
  builtin.initialPeersList.clear();
  const char* env = std::getenv("TANDEM_DDS_PEERS");
  std::istringstream peers(env != nullptr && *env != '\0' ? env : "127.0.0.1");
  for (std::string address; std::getline(peers, address, ',');) {
    if (address.empty()) continue;
    rtps::Locator_t peer;  // port 0: every participant id's metatraffic port, up to maxInitialPeersRange
    peer.kind = LOCATOR_KIND_UDPv4;
    if (!eprosima::fastrtps::rtps::IPLocator::setIPv4(peer, address)) {
      throw std::runtime_error("TANDEM_DDS_PEERS: '" + address + "' is not an IPv4 address");
    }
    builtin.initialPeersList.push_back(peer);
  }
  udp.maxInitialPeersRange = kMaxParticipantId;
}

}  // namespace

Participant::Participant(int domain_id, const std::string& name, Transport transport) : transport_(transport) {
  // DDS-Security (below) keeps the deployment's transport: on one host over shared memory the per-tick topics are
  // governed without per-sample crypto and keep data-sharing (docs/security.md, "Threat model"). Secured
  // participants were held to UDPv4 while a pair sometimes failed to authenticate at start-up (a race in Fast
  // DDS 2.9.1, more frequent over shared memory): the launcher now repairs that by restarting the module.
  transport = transport_;
  fdds::DomainParticipantQos qos = fdds::PARTICIPANT_QOS_DEFAULT;
  qos.name(name);
  qos.transport().use_builtin_transports = false;
  // A process that joins a running deployment (a plugged or restarted robot) must be found fast: announce it
  // ten times, 20 ms apart, instead of Fast DDS's five times 100 ms apart.
  auto& announce = qos.wire_protocol().builtin.discovery_config.initial_announcements;
  announce.count = 10;
  announce.period = eprosima::fastrtps::Duration_t(0, 20000000u);
  // And then every second instead of every 3 s: a pair that missed each other's first announcements (seen
  // once in a few runs: a launcher that never heard its world in a 4 s run) finds each other within a second.
  qos.wire_protocol().builtin.discovery_config.leaseDuration_announcementperiod = eprosima::fastrtps::Duration_t(1, 0);
  // A client of the deployment's Discovery Server (Fast DDS reads ROS_DISCOVERY_SERVER at participant creation).
  const char* server = std::getenv("ROS_DISCOVERY_SERVER");
  const bool server_client = server != nullptr && *server != '\0';
  if (server_client) {
    // Such a client (Fast DDS 2.9.1) announces itself to the server only, and the
    // server runs its relay routine on every announcement it receives. Each pass re-sends, under a new sequence
    // number, every participant announcement that some client has not acknowledged yet, and a client's endpoints
    // are relayed to a peer only once that peer has acknowledged the newest copy. Killed clients never acknowledge
    // until their lease ends, and at one announcement a second from each of ~30 clients the passes came every
    // ~30 ms: faster than a busy world acknowledges, so from then on the world (and the launcher) learnt no new
    // robot at all and modules wore away (docs/soak.md, finding 74: a capture showed the same four announcements
    // re-sent every 30-130 ms with new numbers, never acknowledged). Announce every 5 s (6 passes a second instead
    // of 33), and end a killed client's lease after 12 s instead of 20 s, so that fewer dead clients keep
    // announcements pending. Any message of a live client renews its lease at the server (acknowledgements too).
    // This delays the storm (in soak run 49 it came after 35 minutes instead of 11-23); it does not prevent it.
    auto& dc = qos.wire_protocol().builtin.discovery_config;
    dc.leaseDuration_announcementperiod = eprosima::fastrtps::Duration_t(kServerClientAnnouncementS, 0);
    dc.leaseDuration = eprosima::fastrtps::Duration_t(kServerClientLeaseS, 0);
  }
  // A participant id chosen by the launcher (TANDEM_PARTICIPANT_ID), not the lowest free one: the lowest free id
  // is the one a killed process just left, and with it its shared-memory port, which the others still hold open
  // from before; a newcomer that recreated that port heard nobody (seen in soaks: a restarted process cut off
  // from the domain). The launcher hands out the id left longest ago.
  if (const char* id = std::getenv("TANDEM_PARTICIPANT_ID")) {
    const int n = std::atoi(id);
    if (n >= 0 && n < static_cast<int>(kMaxParticipantId)) qos.wire_protocol().participant_id = n;
  }
  if (transport == Transport::SharedMemory) {
    // Data over shared memory; discovery still needs a UDP locator, so keep UDPv4 beside it.
    qos.transport().user_transports.push_back(
        std::make_shared<eprosima::fastdds::rtps::SharedMemTransportDescriptor>());
  }
  auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
  // Larger socket receive buffers than the system default (208 KiB on Debian): in a lockstep soak of four modules
  // the launcher's discovery socket dropped 16k datagrams and a world's 372 (ss -uam, "d" counter) in bursts when
  // processes came and went about once a second, and newcomers then went unheard. The kernel caps the request at
  // net.core.rmem_max (docs/benchmarks.md, "Soak").
  udp->receiveBufferSize = kUdpReceiveBuffer;
  qos.transport().user_transports.push_back(udp);
  // DDS-Security (docs/security.md): the deployment's keys (TANDEM_SECURITY_DIR, made by `tandem keys`) and this
  // process's identity (TANDEM_IDENTITY), set by runtime::use_security or handed down by the launcher.
  std::string security;
  if (const char* dir = std::getenv("TANDEM_SECURITY_DIR"); dir != nullptr && *dir != '\0') {
    // Files a secured process creates are its user's alone. (The per-tick samples of a secured one-host
    // deployment travel unencrypted through data-sharing segments, which Fast DDS makes 0644 whatever the umask:
    // those go in a private directory, dds::private_shm_dir. docs/security.md, "Threat model".)
    ::umask(077);
  }
  if (const char* dir = std::getenv("TANDEM_SECURITY_DIR"); dir != nullptr && *dir != '\0') {
    const char* id = std::getenv("TANDEM_IDENTITY");
    if (id == nullptr || *id == '\0') {
      throw std::runtime_error("TANDEM_SECURITY_DIR is set but TANDEM_IDENTITY is not: no identity to join with");
    }
    const std::string d = std::string("file://") + dir + "/";  // Fast DDS: file:// and the path (absolute)
    auto& props = qos.properties().properties();
    props.emplace_back("dds.sec.auth.plugin", "builtin.PKI-DH");
    props.emplace_back("dds.sec.auth.builtin.PKI-DH.identity_ca", d + "ca.pem");
    props.emplace_back("dds.sec.auth.builtin.PKI-DH.identity_certificate", d + id + ".pem");
    props.emplace_back("dds.sec.auth.builtin.PKI-DH.private_key", d + id + ".key");
    props.emplace_back("dds.sec.access.plugin", "builtin.Access-Permissions");
    props.emplace_back("dds.sec.access.builtin.Access-Permissions.permissions_ca", d + "ca.pem");
    props.emplace_back("dds.sec.access.builtin.Access-Permissions.governance", d + "governance.p7s");
    props.emplace_back("dds.sec.access.builtin.Access-Permissions.permissions", d + "permissions.p7s");
    props.emplace_back("dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC");
    secured_ = true;
    if (!server_client) single_discovery_thread(qos, *udp);
    security = std::string(" with DDS-Security identity '") + id + "' (keys in " + dir +
               ": missing, expired or not signed by its CA? make them with `tandem keys`)";
  }
  participant_ = fdds::DomainParticipantFactory::get_instance()->create_participant(domain_id, qos);
  if (participant_ == nullptr) {
    throw std::runtime_error("cannot create a DDS participant on domain " + std::to_string(domain_id) + security);
  }
  publisher_ = participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  subscriber_ = participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
}

Participant::~Participant() {
  if (participant_ != nullptr) {
    participant_->delete_contained_entities();
    fdds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }
}

fdds::Topic* Participant::topic(const std::string& name, fdds::TopicDataType* type) {
  fdds::TypeSupport ts(type);
  if (participant_->find_type(ts.get_type_name()).empty()) ts.register_type(participant_);
  if (fdds::TopicDescription* d = participant_->lookup_topicdescription(name)) {
    return static_cast<fdds::Topic*>(d);
  }
  return participant_->create_topic(name, ts.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
}

}  // namespace tandem::dds
