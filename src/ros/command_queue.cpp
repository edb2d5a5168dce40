#include "fem_cloth/ros/command_queue.h"

#include <algorithm>

namespace fem_cloth {

const char* topicName(CommandTopic topic) {
  static const std::array<const char*, kCommandTopics> names = [] {
    std::array<const char*, kCommandTopics> out{};
    forEachCommandType([&out](auto type) {
      using C = typename decltype(type)::type;
      out[static_cast<std::size_t>(topicOf<C>())] = CommandTraits<C>::name;
    });
    return out;
  }();
  return names[static_cast<std::size_t>(topic)];
}

std::array<CommandTopic, kCommandTopics> commandTopics() {
  std::array<CommandTopic, kCommandTopics> out{};
  for (std::size_t k = 0; k < kCommandTopics; ++k) out[k] = static_cast<CommandTopic>(k);
  return out;
}

Status CommandQueue::push(double time, Command command) {
  if (pending_.size() >= capacity_) {
    return Error{std::to_string(pending_.size()) +
                 " commands are already waiting for their time (max_pending_commands = " +
                 std::to_string(capacity_) + "): refused"};
  }
  ++perTopic_[static_cast<std::size_t>(topicOf(command))];
  auto it = std::upper_bound(pending_.begin(), pending_.end(), time,
                             [](double t, const Pending& p) { return t < p.time; });
  pending_.insert(it, Pending{time, std::move(command)});
  return Status::success();
}

std::vector<Command> CommandQueue::takeDue(double time) {
  std::vector<Command> out;
  while (!pending_.empty() && pending_.front().time <= time) {
    --perTopic_[static_cast<std::size_t>(topicOf(pending_.front().command))];
    out.push_back(std::move(pending_.front().command));
    pending_.pop_front();
  }
  return out;
}

std::vector<const Command*> CommandQueue::due(double time) const {
  std::vector<const Command*> out;
  for (const Pending& p : pending_) {
    if (p.time > time) break;
    out.push_back(&p.command);
  }
  return out;
}

void CommandQueue::retime(const std::function<double(const Command&, double)>& timeOf) {
  for (Pending& p : pending_) p.time = timeOf(p.command, p.time);
  std::stable_sort(pending_.begin(), pending_.end(), [](const Pending& a, const Pending& b) { return a.time < b.time; });
}

std::array<std::uint64_t, kCommandTopics> CommandQueue::clear() {
  const std::array<std::uint64_t, kCommandTopics> dropped = perTopic_;
  pending_.clear();
  perTopic_ = {};
  return dropped;
}

bool CommandInbox::push(Command command) {
  const std::size_t topic = static_cast<std::size_t>(topicOf(command));
  std::lock_guard<std::mutex> lock(mutex_);
  ++tally_[topic].received;
  if (waiting_.size() >= capacity_) {
    ++tally_[topic].refused;
    return false;
  }
  ++tally_[topic].waiting;
  waiting_.push_back(std::move(command));
  return true;
}

void CommandInbox::refuse(CommandTopic topic) {
  std::lock_guard<std::mutex> lock(mutex_);
  Tally& t = tally_[static_cast<std::size_t>(topic)];
  ++t.received;
  ++t.invalid;
}

std::vector<Command> CommandInbox::take() {
  std::vector<Command> out;
  std::lock_guard<std::mutex> lock(mutex_);
  out.swap(waiting_);
  for (Tally& t : tally_) t.waiting = 0;
  return out;
}

CommandInbox::Tally CommandInbox::tally(CommandTopic topic) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return tally_[static_cast<std::size_t>(topic)];
}

CommandStats toMsg(CommandTopic topic, const CommandCounts& counts) {
  CommandStats msg;
  msg.topic = topicName(topic);
  msg.received = counts.received;
  msg.rejected = counts.rejected;
  msg.applied = counts.applied;
  msg.pending = counts.pending;
  msg.discarded = counts.discarded;
  return msg;
}

CommandCounts combinedCounts(const CommandInbox::Tally& inbox, const CommandCounts& driver) {
  CommandCounts c = driver;
  c.received = inbox.received;
  c.rejected += inbox.refused + inbox.invalid;
  c.pending += inbox.waiting;
  return c;
}

}  // namespace fem_cloth
