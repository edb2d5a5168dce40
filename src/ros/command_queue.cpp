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

Status CommandQueue::push(double time, Command command, double now, std::uint64_t ticket) {
  const std::size_t topic = static_cast<std::size_t>(topicOf(command));
  // Those for the next step leave at it: only commands for later can pile up.
  if (time > now && perTopic_[topic] >= capacity_) {
    return Error{std::to_string(perTopic_[topic]) + " ~" + topicName(topicOf(command)) +
                 " commands are already waiting for their time (max_pending_commands = " +
                 std::to_string(capacity_) + "): refused"};
  }
  ++perTopic_[topic];
  auto it = std::upper_bound(pending_.begin(), pending_.end(), time,
                             [](double t, const Pending& p) { return t < p.time; });
  pending_.insert(it, Pending{time, std::move(command), ticket});
  return Status::success();
}

std::vector<Command> CommandQueue::takeDue(double time, std::vector<std::uint64_t>* tickets, bool ticketedOnly) {
  std::vector<Command> out;
  std::deque<Pending> kept;  // due, but without a ticket when only those are taken
  while (!pending_.empty() && pending_.front().time <= time) {
    Pending& p = pending_.front();
    if (ticketedOnly && p.ticket == 0) {
      kept.push_back(std::move(p));
    } else {
      --perTopic_[static_cast<std::size_t>(topicOf(p.command))];
      out.push_back(std::move(p.command));
      if (tickets != nullptr) tickets->push_back(p.ticket);
    }
    pending_.pop_front();
  }
  pending_.insert(pending_.begin(), std::make_move_iterator(kept.begin()), std::make_move_iterator(kept.end()));
  return out;
}

bool CommandQueue::ticketedDue(double time) const {
  for (const Pending& p : pending_) {
    if (p.time > time) return false;
    if (p.ticket != 0) return true;
  }
  return false;
}

std::vector<std::uint64_t> CommandQueue::withdrawTicketed(std::array<std::uint64_t, kCommandTopics>& dropped) {
  std::vector<std::uint64_t> tickets;
  std::deque<Pending> kept;
  for (Pending& p : pending_) {
    if (p.ticket == 0) {
      kept.push_back(std::move(p));
      continue;
    }
    const std::size_t topic = static_cast<std::size_t>(topicOf(p.command));
    --perTopic_[topic];
    ++dropped[topic];
    tickets.push_back(p.ticket);
  }
  pending_.swap(kept);
  return tickets;
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

bool CommandInbox::push(Command command, std::uint64_t ticket) {
  const std::size_t topic = static_cast<std::size_t>(topicOf(command));
  std::lock_guard<std::mutex> lock(mutex_);
  ++tally_[topic].received;
  if (waiting_.size() >= capacity_) {
    ++tally_[topic].refused;
    return false;
  }
  ++tally_[topic].waiting;
  waiting_.push_back(std::move(command));
  tickets_.push_back(ticket);
  return true;
}

void CommandInbox::refuse(CommandTopic topic) {
  std::lock_guard<std::mutex> lock(mutex_);
  Tally& t = tally_[static_cast<std::size_t>(topic)];
  ++t.received;
  ++t.invalid;
}

std::vector<Command> CommandInbox::take(std::vector<std::uint64_t>* tickets) {
  std::vector<Command> out;
  std::lock_guard<std::mutex> lock(mutex_);
  out.swap(waiting_);
  if (tickets != nullptr) tickets->insert(tickets->end(), tickets_.begin(), tickets_.end());
  tickets_.clear();
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
