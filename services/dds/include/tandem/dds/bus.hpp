// Thin DDS layer: one participant per process, typed writers and readers, QoS from one place (qos.cpp).
// Adapters between IDL types and Eigen live in adapters.hpp; transport set-up here; no control logic.
#pragma once

#include <fastdds/dds/core/status/PublicationMatchedStatus.hpp>
#include <fastdds/dds/core/status/SubscriptionMatchedStatus.hpp>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <stdexcept>
#include <string>

#include "tandem/dds/qos.hpp"

namespace tandem::dds {

namespace fdds = eprosima::fastdds::dds;

enum class Transport { SharedMemory, Udp };

/// Participant ids in use are below this (TANDEM_PARTICIPANT_ID; a secured participant announces itself to the
/// metatraffic ports of ids 0 to kMaxParticipantId - 1).
constexpr unsigned kMaxParticipantId = 120;

/// One DDS participant (one per process). Creates topics on demand and deletes everything it created.
class Participant {
 public:
  Participant(int domain_id, const std::string& name, Transport transport);
  ~Participant();
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  /// Registers the type (once) and returns the topic (created once per name).
  fdds::Topic* topic(const std::string& name, fdds::TopicDataType* type);
  fdds::Publisher* publisher() { return publisher_; }
  fdds::Subscriber* subscriber() { return subscriber_; }
  fdds::DomainParticipant* get() { return participant_; }
  /// Per-tick topics use data-sharing delivery unless the deployment asked for UDP only.
  bool data_sharing() const { return transport_ == Transport::SharedMemory; }
  /// The participant joined with DDS-Security (TANDEM_SECURITY_DIR was set).
  bool secured() const { return secured_; }

 private:
  fdds::DomainParticipant* participant_ = nullptr;
  fdds::Publisher* publisher_ = nullptr;
  fdds::Subscriber* subscriber_ = nullptr;
  Transport transport_ = Transport::SharedMemory;
  bool secured_ = false;
};

template <class T, class PubSubType>
class Writer {
 public:
  Writer(Participant& p, const std::string& topic_name, TopicKind kind, int32_t strength = 0) : p_(p) {
    fdds::Topic* t = p.topic(topic_name, new PubSubType());
    writer_ = p.publisher()->create_datawriter(t, writer_qos(kind, strength, p.data_sharing()));
    if (writer_ == nullptr) throw std::runtime_error("cannot create a DDS writer on " + topic_name);
    reliable_shared_ = shares_data(kind, p.data_sharing()) && kind != TopicKind::SensorsRealtime &&
                       kind != TopicKind::TorquesRealtime;
  }
  ~Writer() { p_.publisher()->delete_datawriter(writer_); }
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;
  /// Writes one sample. A reliable data-sharing writer whose payload pool ran dry is unstuck once (see
  /// below) and the sample written again; false if it still cannot be written.
  bool write(T& sample) {
    const ReturnCode_t rc = writer_->write(&sample, fdds::HANDLE_NIL);
    if (rc == ReturnCode_t::RETCODE_OK) return true;
    if (!reliable_shared_ || rc != ReturnCode_t::RETCODE_OUT_OF_RESOURCES) return false;
    // Fast DDS 2.9: a volatile reader that matches while another reader's acknowledgement is being processed
    // can leave one change never reported as acknowledged by all. It is never removed, and the data-sharing pool
    // frees its slots only in order behind it: some 260 writes later every write fails, for good (the history
    // holds too few changes for keep-last to evict it). Seen as a lockstep arm braked for good after a third
    // robot was plugged (soak run 24; fixed upstream by Fast DDS PR #5859, in 3.5). Clearing the history frees
    // the whole ring; a reader that had not yet read the cleared samples misses them (readers detect that).
    size_t removed = 0;
    if (writer_->clear_history(&removed) != ReturnCode_t::RETCODE_OK) return false;
    ++history_clears_;
    return writer_->write(&sample, fdds::HANDLE_NIL) == ReturnCode_t::RETCODE_OK;
  }
  /// Disposes of the instance `key` names (a keyed topic): a reader that joins later is not handed its last sample.
  bool dispose(T& key) { return writer_->dispose(&key, fdds::HANDLE_NIL) == ReturnCode_t::RETCODE_OK; }
  /// How often write() found the pool dry and cleared the history (0 in a healthy run; a secured deployment's
  /// lockstep topics are the ones that can need it: the others do not go by data-sharing).
  long history_clears() const { return history_clears_; }
  /// Waits until every matched reader has acknowledged what was written (reliable topics), up to timeout_s.
  bool wait_for_acks(double timeout_s) {
    const auto sec = static_cast<int32_t>(timeout_s);
    const auto nsec = static_cast<uint32_t>((timeout_s - sec) * 1e9);
    return writer_->wait_for_acknowledgments(eprosima::fastrtps::Duration_t(sec, nsec)) == ReturnCode_t::RETCODE_OK;
  }
  int matched() const {
    fdds::PublicationMatchedStatus st;
    writer_->get_publication_matched_status(st);
    return st.current_count;
  }

 private:
  Participant& p_;
  fdds::DataWriter* writer_ = nullptr;
  bool reliable_shared_ = false;
  long history_clears_ = 0;
};

template <class T, class PubSubType>
class Reader {
 public:
  /// With a listener, its on_data_available runs in the DDS thread that received the sample (no hand-off to
  /// another thread); the listener must outlive the reader.
  Reader(Participant& p, const std::string& topic_name, TopicKind kind, fdds::DataReaderListener* listener = nullptr)
      : p_(p) {
    fdds::Topic* t = p.topic(topic_name, new PubSubType());
    reader_ = listener == nullptr ? p.subscriber()->create_datareader(t, reader_qos(kind, p.data_sharing()))
                                  : p.subscriber()->create_datareader(t, reader_qos(kind, p.data_sharing()), listener,
                                                                      fdds::StatusMask::data_available());
    if (reader_ == nullptr) throw std::runtime_error("cannot create a DDS reader on " + topic_name);
  }
  ~Reader() { p_.subscriber()->delete_datareader(reader_); }
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;
  /// Takes the next valid sample, if any.
  bool take(T& out) {
    fdds::SampleInfo info;
    while (reader_->take_next_sample(&out, &info) == ReturnCode_t::RETCODE_OK) {
      if (info.valid_data) return true;
    }
    return false;
  }
  /// Waits up to timeout_s for an unread sample.
  bool wait(double timeout_s) {
    const auto sec = static_cast<int32_t>(timeout_s);
    const auto nsec = static_cast<uint32_t>((timeout_s - sec) * 1e9);
    return reader_->wait_for_unread_message(eprosima::fastrtps::Duration_t(sec, nsec));
  }
  fdds::DataReader* get() { return reader_; }
  int matched() const {
    fdds::SubscriptionMatchedStatus st;
    reader_->get_subscription_matched_status(st);
    return st.current_count;
  }

 private:
  Participant& p_;
  fdds::DataReader* reader_ = nullptr;
};

}  // namespace tandem::dds
