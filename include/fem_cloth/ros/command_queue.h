// Where pin and force commands wait, and what became of them (docs/node.md, Commands).
//
// A command arrives on a topic into the node's CommandInbox (thread-safe: a subscriber callback
// only appends, it never waits for a step), is validated between steps by the SimulationDriver
// and queued in its CommandQueue (stamp order) until its time comes. Both are bounded: beyond
// their capacity a command is refused, counted and reported, never dropped in silence.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "fem_cloth/CommandStats.h"
#include "fem_cloth/ForceCommand.h"
#include "fem_cloth/GraspCommand.h"
#include "fem_cloth/ObstacleCommand.h"
#include "fem_cloth/PinCommand.h"
#include "fem_cloth/SetCommand.h"
#include "fem_cloth/core/expected.h"

namespace fem_cloth {

// The command topics. Adding one: its message (msg/), its line here (the variant and its
// traits), its check and apply in simulation_driver.cpp, and CMakeLists.txt (the message). The
// node subscribes to it and publishes it as applied, bags record and replay it, and its counts
// are reported, all from this list (docs/architecture.md, the ROS side).
template <class C>
struct CommandTraits;
template <>
struct CommandTraits<PinCommand> {
  static constexpr const char* name = "pin";  ///< ~pin; as applied: ~applied_pin
};
template <>
struct CommandTraits<ForceCommand> {
  static constexpr const char* name = "force";
};
template <>
struct CommandTraits<SetCommand> {
  static constexpr const char* name = "set";  ///< also the ~set service
};
template <>
struct CommandTraits<ObstacleCommand> {
  static constexpr const char* name = "obstacle";  ///< also ~add_obstacle, ~remove_obstacle, ~move_obstacle
};
template <>
struct CommandTraits<GraspCommand> {
  static constexpr const char* name = "grasp";  ///< also the ~grasp_nearest service
};

using Command = std::variant<PinCommand, ForceCommand, SetCommand, ObstacleCommand, GraspCommand>;
constexpr std::size_t kCommandTopics = std::variant_size_v<Command>;

/// A topic by its index in Command (Pin and Force named for the code that means them).
enum class CommandTopic : std::size_t { Pin = 0, Force = 1, Set = 2, Obstacle = 3, Grasp = 4 };

inline CommandTopic topicOf(const Command& c) { return static_cast<CommandTopic>(c.index()); }
template <class C>
constexpr CommandTopic topicOf() {
  return static_cast<CommandTopic>(Command(C()).index());
}
/// The topic's name under the node ("pin", "force").
const char* topicName(CommandTopic topic);
/// Every topic, in Command's order.
std::array<CommandTopic, kCommandTopics> commandTopics();

template <class C>
struct CommandType {
  using type = C;
};
template <class F, std::size_t... I>
void forEachCommandType(F&& f, std::index_sequence<I...>) {
  (f(CommandType<std::variant_alternative_t<I, Command>>()), ...);
}
/// Calls f(CommandType<C>()) for each command type C, in Command's order.
template <class F>
void forEachCommandType(F&& f) {
  forEachCommandType(f, std::make_index_sequence<kCommandTopics>());
}

/// The header of any command.
inline const std_msgs::Header& headerOf(const Command& c) {
  return std::visit([](const auto& command) -> const std_msgs::Header& { return command.header; }, c);
}

/// What became of the commands of one topic. received = rejected + applied + pending + discarded.
struct CommandCounts {
  std::uint64_t received = 0;
  std::uint64_t rejected = 0;   ///< invalid, over a capacity, or failed when due
  std::uint64_t applied = 0;    ///< took effect before a step
  std::uint64_t pending = 0;    ///< waiting (to be validated, or for their stamp)
  std::uint64_t discarded = 0;  ///< still pending when ~reset dropped them
};

/// Validated commands waiting for their simulation time, in time order (equal times keep their
/// arrival order, so a replayed stream applies the same way). Each topic may hold at most
/// `capacity` commands for a later step: one topic's future commands never crowd out another's,
/// and a command for the next step is never refused.
class CommandQueue {
 public:
  explicit CommandQueue(std::size_t capacity) : capacity_(capacity) {}

  /// Queues `command` to take effect at simulation time `time` (<= now: before the next step),
  /// after those due at the same time or earlier. A command for later is refused, naming the
  /// capacity, when `capacity` commands of its topic already wait. `ticket` (0: none) follows
  /// the command to takeDue(), for whoever waits for its outcome.
  Status push(double time, Command command, double now = -1.0, std::uint64_t ticket = 0);
  /// Removes and returns the commands due at or before `time`, in order (their tickets, in the
  /// same order, into `tickets` when given); with `ticketedOnly`, only those with a ticket.
  std::vector<Command> takeDue(double time, std::vector<std::uint64_t>* tickets = nullptr, bool ticketedOnly = false);
  /// Whether a command with a ticket is due at or before `time`.
  bool ticketedDue(double time) const;
  /// Removes the commands that carry a ticket; returns their tickets and adds them to `dropped`
  /// (per topic).
  std::vector<std::uint64_t> withdrawTicketed(std::array<std::uint64_t, kCommandTopics>& dropped);
  /// The commands due at or before `time`, left in the queue.
  std::vector<const Command*> due(double time) const;
  /// Drops every command; returns how many of each topic were dropped.
  std::array<std::uint64_t, kCommandTopics> clear();
  /// Times every command anew with timeOf(command, its time now), keeping the order of equal
  /// times: the mapping of stamps to simulation times changed (a new segment, timeline.h).
  void retime(const std::function<double(const Command&, double)>& timeOf);

  std::size_t size() const { return pending_.size(); }
  std::uint64_t size(CommandTopic topic) const { return perTopic_[static_cast<std::size_t>(topic)]; }
  std::size_t capacity() const { return capacity_; }

 private:
  struct Pending {
    double time;
    Command command;
    std::uint64_t ticket;
  };
  std::size_t capacity_;
  std::deque<Pending> pending_;
  std::array<std::uint64_t, kCommandTopics> perTopic_{};
};

/// Commands as they arrive, for the run loop to take between steps. Thread-safe. At most
/// `capacity` wait; beyond that push() refuses and counts the command.
class CommandInbox {
 public:
  explicit CommandInbox(std::size_t capacity) : capacity_(capacity) {}

  /// False (the command is counted as refused) when `capacity` commands already wait.
  /// `ticket` (0: none) comes out of take() with the command.
  bool push(Command command, std::uint64_t ticket = 0);
  /// Counts a request of `topic` that a service refused on its own check (received, invalid).
  void refuse(CommandTopic topic);
  /// Every waiting command, in arrival order (their tickets, in the same order, into `tickets`
  /// when given).
  std::vector<Command> take(std::vector<std::uint64_t>* tickets = nullptr);

  struct Tally {
    std::uint64_t received = 0, refused = 0, waiting = 0;
    std::uint64_t invalid = 0;  ///< refused by a service's check (refused: by the capacity)
  };
  Tally tally(CommandTopic topic) const;
  std::size_t capacity() const { return capacity_; }

 private:
  std::size_t capacity_;
  mutable std::mutex mutex_;
  std::vector<Command> waiting_;
  std::vector<std::uint64_t> tickets_;
  std::array<Tally, kCommandTopics> tally_{};
};

CommandStats toMsg(CommandTopic topic, const CommandCounts& counts);

/// The counts a node reports: those of its inbox (commands not yet validated, or refused by the
/// inbox) added to those of its driver.
CommandCounts combinedCounts(const CommandInbox::Tally& inbox, const CommandCounts& driver);

}  // namespace fem_cloth
