// Rate-limited log lines that still count everything. ROS's *_THROTTLE macros drop the lines in
// between without a word; a node that rejected 20 000 commands must neither print 20 000 lines
// nor hide how many there were. Per kind of message, the first one of a window of `period`
// seconds is logged at once; the rest are counted, and when the window has passed one line says
// how many there were and repeats the latest.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace fem_cloth {

class WarningThrottle {
 public:
  explicit WarningThrottle(double period = 1.0) : period_(period) {}

  /// A message of `kind` at time `now` (s, a monotonic clock). Returns the lines to log now: the
  /// summary of this kind's last window if it has passed, and the message itself if it opens a
  /// new window. A summary reads "<N> more <label> in the 1 s that followed (latest: ...)";
  /// the label is the kind unless given (e.g. kind "~force rejected").
  std::vector<std::string> add(const std::string& kind, const std::string& message, double now,
                               const std::string& label = "");
  /// The summaries of the windows that have passed by `now`. Call it regularly, so that the
  /// count of a burst is told even when nothing follows it.
  std::vector<std::string> flush(double now);

  /// A kind for messages that differ only in their numbers (times, vertices, counts): the
  /// message with every number (a digit, then digits and points) replaced by '#'.
  static std::string kindOf(const std::string& message);

 private:
  struct Window {
    double start = 0.0;
    std::uint64_t suppressed = 0;
    std::string latest;
    std::string label;
  };
  /// The summary line of a passed window, if it suppressed anything; the window is closed.
  void close(const Window& w, std::vector<std::string>* lines) const;

  double period_;
  std::map<std::string, Window> open_;
};

}  // namespace fem_cloth
