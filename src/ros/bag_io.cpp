#include "fem_cloth/ros/bag_io.h"

#include <console_bridge/console.h>
#include <rosbag/exceptions.h>
#include <rosbag/view.h>
#include <std_msgs/String.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <array>
#include <map>
#include <sstream>

#include "fem_cloth/ClothState.h"
#include "fem_cloth/io/output_file.h"
#include "fem_cloth/io/scene_yaml.h"
#include "fem_cloth/ros/time_checks.h"
#include "fem_cloth/ros/time_text.h"

namespace fem_cloth {

RunTopics::RunTopics(const std::string& node) {
  std::string ns = node.empty() ? "/fem_cloth_node" : node;
  if (ns[0] != '/') ns = "/" + ns;
  if (ns.back() == '/') ns.pop_back();
  this->ns = ns;
  scene = ns + "/scene";
  mesh = ns + "/mesh";
  state = ns + "/state";
  energy = ns + "/energy";
  stats = ns + "/stats";
  pinForces = ns + "/pin_forces";
  pinWrench = ns + "/pin_wrench";
  pin = ns + "/pin";
  force = ns + "/force";
  appliedPin = ns + "/applied_pin";
  appliedForce = ns + "/applied_force";
}

std::string RunTopics::sent(CommandTopic topic) const { return ns + "/" + topicName(topic); }
std::string RunTopics::applied(CommandTopic topic) const { return ns + "/applied_" + topicName(topic); }

namespace {

template <class M>
Status expectType(const rosbag::ConnectionInfo& c) {
  const std::string type = ros::message_traits::DataType<M>::value();
  const std::string md5 = ros::message_traits::MD5Sum<M>::value();
  if (c.datatype != type) {
    return Error{"topic " + c.topic + " holds " + printableText(c.datatype) + " messages, expected " + type};
  }
  if (c.md5sum != md5) {
    return Error{"topic " + c.topic + " holds " + type +
                 " messages of another definition (md5 " + printableText(c.md5sum) + ", this build " + md5 +
                 "): recorded with an incompatible version of fem_cloth"};
  }
  return Status::success();
}

// Every topic we read has the type we read it as, checked before reading any of them.
Status checkTypes(rosbag::View& view, const RunTopics& topics) {
  for (const rosbag::ConnectionInfo* c : view.getConnections()) {
    Status s;
    if (c->topic == topics.scene) s = expectType<std_msgs::String>(*c);
    if (c->topic == topics.mesh) s = expectType<shape_msgs::Mesh>(*c);
    if (c->topic == topics.state) s = expectType<ClothState>(*c);
    if (c->topic == "/tf" || c->topic == "/tf_static") s = expectType<tf2_msgs::TFMessage>(*c);
    forEachCommandType([&](auto type) {
      using C = typename decltype(type)::type;
      const CommandTopic topic = topicOf<C>();
      if (c->topic == topics.sent(topic) || c->topic == topics.applied(topic)) s = expectType<C>(*c);
    });
    if (!s) return s;
  }
  return Status::success();
}

// A command message read, and whether it was sent (NS/<t>) or applied (NS/applied_<t>).
struct ReadCommand {
  Command command;
  bool sent = false;
};

// A command message, sent or applied (a sent one with a zero stamp is stamped with the time it
// was recorded: when the node took it); none when the message is no command.
std::optional<ReadCommand> readCommand(const rosbag::MessageInstance& m, const RunTopics& topics) {
  std::optional<ReadCommand> read;
  forEachCommandType([&](auto type) {
    using C = typename decltype(type)::type;
    const CommandTopic topic = topicOf<C>();
    const bool isSent = m.getTopic() == topics.sent(topic);
    if (!isSent && m.getTopic() != topics.applied(topic)) return;
    auto msg = m.instantiate<C>();
    if (!msg) return;
    C c = *msg;
    if (isSent && c.header.stamp.isZero()) c.header.stamp = m.getTime();
    read = ReadCommand{std::move(c), isSent};
  });
  return read;
}

Status checkStamp(const ros::Time& stamp, const ros::Time& begin, const std::string& what) {
  if (stamp.isZero()) return Status::success();  // "now" for commands, static for tf
  const double distance = std::abs(secondsBetween(stamp, begin));
  if (!(distance <= kMaxRecordingSpan)) {
    return Error{what + " has the stamp " + rosTimeText(stamp) + " s, " + numberText(distance) +
                 " s from the start of the recording (" + rosTimeText(begin) +
                 " s): more than the " + numberText(kMaxRecordingSpan) + " s a recording can span"};
  }
  return Status::success();
}

// What one message of the bag adds to the run; the message is named in errors.
class RunReader {
 public:
  RunReader(RecordedRun& run, const RunTopics& topics) : run_(run), topics_(topics) {}

  /// Adds the next message in bag order; a message that does not deserialise (a damaged or cut
  /// one) is an error naming it: its place in the bag, its topic and its bag time.
  Status add(const rosbag::MessageInstance& m) {
    const std::string what = "message " + std::to_string(++count_) + " (" + printableText(m.getTopic()) +
                             ", bag time " + rosTimeText(m.getTime()) + " s)";
    try {
      return addMessage(m, what);
    } catch (const ros::Exception& e) {
      // ros::serialization's Buffer Overrun; rosbag's and lz4's errors on its record or chunk.
      return Error{what + " cannot be read (truncated or damaged): " + e.what()};
    } catch (const std::bad_alloc& e) {
      // A garbled length.
      return Error{what + " cannot be read (truncated or damaged): " + e.what()};
    }
  }

 private:
  Status addMessage(const rosbag::MessageInstance& m, const std::string& what) {
    const std::string& topic = m.getTopic();
    FEM_CLOTH_CHECK(checkStamp(m.getTime(), run_.begin, what));
    if (topic == topics_.scene) {
      if (auto msg = m.instantiate<std_msgs::String>()) run_.sceneYaml = msg->data;
    } else if (topic == topics_.mesh) {
      if (auto msg = m.instantiate<shape_msgs::Mesh>(); msg && !run_.mesh) run_.mesh = *msg;
    } else if (topic == topics_.state) {
      if (auto msg = m.instantiate<ClothState>()) return addState(*msg, m.getTime(), what);
    } else if (std::optional<ReadCommand> c = readCommand(m, topics_)) {
      // The node refuses a command stamped beyond what a ROS duration can hold (and records
      // it all the same, as sent): the replay leaves it out as the node did, with a warning,
      // rather than refusing the whole recording for it.
      if (Status s = checkStamp(headerOf(c->command).stamp, run_.begin, what); !s) {
        run_.warnings.push_back(s.error() + "; left out, as the node refuses such a command");
      } else {
        const std::size_t k = static_cast<std::size_t>(topicOf(c->command));
        (c->sent ? sent_ : applied_)[k].push_back(std::move(c->command));
      }
      return Status::success();
    } else if (topic == "/tf" || topic == "/tf_static") {
      if (auto msg = m.instantiate<tf2_msgs::TFMessage>()) {
        for (const auto& t : msg->transforms) {
          const std::string frame = "frame '" + printableText(t.child_frame_id) + "'";
          FEM_CLOTH_CHECK(checkStamp(t.header.stamp, run_.begin, what + ", " + frame));
          // tf refuses what a live listener would refuse too (a NaN, a rotation that is not a
          // unit quaternion, an empty or self-referencing frame): the replay goes on without it.
          if (!run_.tf->setTransform(t, "bag", topic == "/tf_static")) {
            run_.warnings.push_back(what + ": tf refused the transform of " + frame +
                                    " (not finite, not a rotation, or no frames named)");
          }
        }
      }
    }
    return Status::success();
  }

 public:
  /// The commands to replay: the applied ones when the bag has them (exact), else those sent.
  void finish() {
    bool anyApplied = false, anySent = false;
    for (std::size_t k = 0; k < kCommandTopics; ++k) {
      anyApplied = anyApplied || !applied_[k].empty();
      anySent = anySent || !sent_[k].empty();
    }
    run_.exactCommands = anyApplied || !anySent;
    for (std::vector<Command>& topic : run_.exactCommands ? applied_ : sent_) {
      for (Command& c : topic) run_.commands.push_back(std::move(c));
    }
  }

 private:
  Status addState(const ClothState& msg, const ros::Time& time, const std::string& what) {
    FEM_CLOTH_CHECK(checkStamp(msg.header.stamp, run_.begin, what));
    // A node reset (~reset) starts again from step 0: the commands before and after it cannot
    // be told apart by their stamps, so no replay can reproduce the recording.
    if (!run_.states.empty() && msg.step < run_.states.back().step) {
      return Error{"it spans a reset of the node (~reset): the state's step goes back from " +
                   std::to_string(run_.states.back().step) + " to " + std::to_string(msg.step) +
                   " at bag time " + rosTimeText(time) +
                   " s; replay the part before or after it (rosbag filter ... \"t.to_nsec() < " +
                   std::to_string(time.toNSec()) + "\", then --scene for the part after)"};
    }
    if (run_.frame.empty()) run_.frame = msg.header.frame_id;
    run_.states.push_back({msg.step, msg.header.stamp, msg.state_hash});
    return Status::success();
  }

  RecordedRun& run_;
  const RunTopics& topics_;
  std::size_t count_ = 0;
  std::array<std::vector<Command>, kCommandTopics> sent_, applied_;
};

// rosbag and tf2 also print what they find wrong (a damaged record header, a refused transform)
// through console_bridge, in several lines of their own; here it comes back as one error or
// warning, so the console is quiet while a bag is read.
class QuietConsole {
 public:
  QuietConsole() : level_(console_bridge::getLogLevel()) {
    console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE);
  }
  ~QuietConsole() { console_bridge::setLogLevel(level_); }

 private:
  console_bridge::LogLevel level_;
};

}  // namespace

Expected<YAML::Node> storedScene(const RecordedRun& run, const std::string& node) {
  if (run.sceneYaml.empty()) {
    return Error{"bag '" + run.path + "' holds no scene (" + RunTopics(node).scene +
                 "): record with launch/record.launch, or give the scene"};
  }
  // As a scene file is read: bounded in size, one document.
  return parseSceneText(run.sceneYaml, "the scene stored in bag '" + run.path + "'");
}

namespace {

// The fields of a bag record's header (bag format 2.0: each field a 4-byte length, then
// "name=value").
std::map<std::string, std::string> recordFields(const std::string& header) {
  std::map<std::string, std::string> out;
  std::size_t i = 0;
  while (i + 4 <= header.size()) {
    std::uint32_t length = 0;
    std::memcpy(&length, header.data() + i, 4);
    i += 4;
    if (length > header.size() - i) break;
    const std::string field = header.substr(i, length);
    i += length;
    const std::size_t eq = field.find('=');
    if (eq != std::string::npos) out[field.substr(0, eq)] = field.substr(eq + 1);
  }
  return out;
}

// rosbag reads a message at the offset the chunk's index gives without checking it against the
// chunk: a damaged offset made it read outside the chunk's buffer and crash (SIGSEGV in
// readHeaderFromBuffer; test/data/fuzz/index_offset_outside_chunk.bag). So the index records
// after each chunk are checked here first: every offset, plus the 4 bytes of a record's header
// length, within the chunk's uncompressed size. Records this walk cannot follow (a truncated
// file) are left to rosbag, which refuses those with an exception.
Status checkChunkIndex(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string magic;
  if (!std::getline(in, magic)) return Status::success();
  std::uint64_t chunkSize = 0;
  bool inChunk = false;
  int chunks = 0;
  auto readLength = [&](std::uint32_t& value) { return static_cast<bool>(in.read(reinterpret_cast<char*>(&value), 4)); };
  constexpr std::uint32_t kLargestHeader = 1u << 20;
  while (true) {
    const std::streamoff at = in.tellg();
    std::uint32_t headerLength = 0, dataLength = 0;
    if (!readLength(headerLength) || headerLength > kLargestHeader) return Status::success();
    std::string header(headerLength, '\0');
    if (!in.read(header.data(), headerLength) || !readLength(dataLength)) return Status::success();
    const std::map<std::string, std::string> fields = recordFields(header);
    const auto op = fields.find("op");
    const char code = op != fields.end() && op->second.size() == 1 ? op->second[0] : 0;
    if (code == 0x05) {  // a chunk: its uncompressed size
      const auto size = fields.find("size");
      if (size == fields.end() || size->second.size() != 4) return Status::success();
      std::uint32_t value = 0;
      std::memcpy(&value, size->second.data(), 4);
      chunkSize = value;
      inChunk = true;
      ++chunks;
    } else if (code == 0x04 && inChunk) {  // an index record of that chunk: (time, offset) pairs
      std::string data(dataLength, '\0');
      if (!in.read(data.data(), dataLength)) return Status::success();
      for (std::size_t k = 0; k + 12 <= data.size(); k += 12) {
        std::uint32_t offset = 0;
        std::memcpy(&offset, data.data() + k + 8, 4);
        if (static_cast<std::uint64_t>(offset) + 4 > chunkSize) {
          std::ostringstream msg;
          msg << "bag '" << path << "' is damaged: the index of chunk " << chunks << " (record at byte " << at
              << ") puts message " << k / 12 + 1 << " at byte " << offset << " of a chunk of " << chunkSize
              << " bytes: 'rosbag reindex' may recover what it holds";
          return Error{msg.str()};
        }
      }
      continue;
    } else if (code != 0x04) {
      inChunk = false;
    }
    in.seekg(dataLength, std::ios::cur);
    if (!in) return Status::success();
  }
}

// Opens the bag at `path` for reading; the error names what is wrong with it.
Status openBag(rosbag::Bag& bag, const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return Error{"no bag at '" + path + "'"};
  if (!std::filesystem::is_regular_file(path, ec)) {
    return Error{"'" + path + "' is not a bag: not a regular file"};
  }
  if (Status s = checkChunkIndex(path); !s) return s;
  try {
    bag.open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagUnindexedException&) {
    return Error{"bag '" + path + "' is truncated or was not closed (no index): "
                 "'rosbag reindex' may recover what it holds"};
  } catch (const rosbag::BagIOException& e) {
    // Reading past the end of the file: the index the header points to is missing.
    return Error{"bag '" + path + "' is truncated or damaged (" + e.what() +
                 "): 'rosbag reindex' may recover what it holds"};
  } catch (const std::exception& e) {
    // rosbag::BagException, and whatever a damaged header makes rosbag throw (bad_alloc on a
    // garbled length).
    return Error{"cannot read bag '" + path + "': " + e.what()};
  }
  return Status::success();
}

}  // namespace

Expected<RecordedRun> readRun(const std::string& path, const std::string& node) {
  const QuietConsole quiet;
  const RunTopics topics(node);
  RecordedRun run;
  run.path = path;
  rosbag::Bag bag;
  if (Status s = openBag(bag, path); !s) return Error{s.error()};
  try {
    rosbag::View view(bag);
    if (view.size() == 0) return Error{"bag '" + path + "' holds no messages"};
    run.begin = view.getBeginTime();
    run.end = view.getEndTime();
    if (Status s = checkTypes(view, topics); !s) return Error{"bag '" + path + "': " + s.error()};
    // tf keeps transforms this long (s): the whole recording.
    const double span = std::min(std::max(secondsBetween(run.end, run.begin), 0.0), kMaxRecordingSpan);
    run.tf = std::make_shared<tf2::BufferCore>(ros::Duration(span + 60.0));
    RunReader reader(run, topics);
    for (const rosbag::MessageInstance& m : view) {
      if (Status s = reader.add(m); !s) return Error{"bag '" + path + "': " + s.error()};
    }
    reader.finish();
  } catch (const std::exception& e) {
    // rosbag's errors on the index, a stamp tf's time arithmetic cannot take.
    return Error{"bag '" + path + "' is truncated or damaged: " + e.what()};
  }
  return run;
}

Expected<std::unique_ptr<StateReader>> StateReader::open(const std::string& path, const std::string& node) {
  const QuietConsole quiet;
  std::unique_ptr<StateReader> reader(new StateReader());
  reader->path_ = path;
  if (Status s = openBag(reader->bag_, path); !s) return Error{s.error()};
  try {
    reader->view_ = std::make_unique<rosbag::View>(reader->bag_, rosbag::TopicQuery(RunTopics(node).state));
    reader->count_ = reader->view_->size();
    reader->it_ = reader->view_->begin();
  } catch (const std::exception& e) {
    return Error{"bag '" + path + "' is truncated or damaged: " + e.what()};
  }
  return reader;
}

Expected<bool> StateReader::next(ClothState& state) {
  const QuietConsole quiet;
  try {
    if (it_ == view_->end()) return false;
    boost::shared_ptr<ClothState> msg = it_->instantiate<ClothState>();
    ++read_;
    ++it_;
    if (!msg) return Error{"bag '" + path_ + "': state " + std::to_string(read_) + " is not a fem_cloth/ClothState"};
    state = std::move(*msg);
  } catch (const std::exception& e) {
    return Error{"bag '" + path_ + "' is truncated or damaged at state " + std::to_string(read_ + 1) + ": " + e.what()};
  }
  return true;
}

std::string StateReader::name(const ClothState& state) const {
  std::ostringstream stamp;
  stamp << state.header.stamp;
  return "recorded state " + std::to_string(read_) + " of " + std::to_string(count_) + " (step " +
         std::to_string(state.step) + ", stamp " + stamp.str() + " s)";
}

namespace {

// Why `values` (points or vectors) cannot be one per vertex of a cloth of `vertices` vertices.
template <class V>
std::string perVertexProblem(const std::vector<V>& values, std::size_t vertices, const char* what,
                             const char* plural) {
  if (values.size() != vertices) {
    return "it holds " + std::to_string(values.size()) + " " + plural + " for the " + std::to_string(vertices) +
           " vertices of the cloth";
  }
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!std::isfinite(values[i].x) || !std::isfinite(values[i].y) || !std::isfinite(values[i].z)) {
      return "the " + std::string(what) + " of vertex " + std::to_string(i) + " is not finite";
    }
  }
  return "";
}

}  // namespace

std::string stateDamage(const ClothState& state, std::size_t vertices) {
  std::string why = perVertexProblem(state.positions, vertices, "position", "positions");
  if (why.empty() && !state.velocities.empty()) why = perVertexProblem(state.velocities, vertices, "velocity", "velocities");
  return why;
}

std::optional<ros::Time> runEpoch(const RecordedRun& run, double dt) {
  if (run.states.empty()) return std::nullopt;
  // The first state after step 0: a node paused from the start moves its origin to ROS time
  // until its first step (docs/node.md, Time), so a step-0 state recorded earlier can be
  // stamped before it.
  const auto stepped = std::find_if(run.states.begin(), run.states.end(), [](const RecordedState& r) { return r.step > 0; });
  const RecordedState& s = stepped != run.states.end() ? *stepped : run.states.back();
  // Only an origin that ros::Time can hold (a state whose step does not fit its stamp and dt
  // has none); Time - Duration keeps the exact nanoseconds of the stamp where it can.
  const double back = static_cast<double>(s.step) * dt;
  if (!(back >= 0.0 && back <= s.stamp.toSec() && back < kMaxRecordingSpan)) return std::nullopt;
  return s.stamp - ros::Duration(back);
}

std::optional<Timeline> runTimeline(const RecordedRun& run, double dt) {
  const std::optional<ros::Time> epoch = runEpoch(run, dt);
  if (!epoch) return std::nullopt;
  Timeline timeline(*epoch);
  // Step-0 states are left to runEpoch: a node paused from the start moves its origin until
  // its first step.
  for (const RecordedState& s : run.states) {
    if (s.step == 0) continue;
    const TimelineSegment& in = timeline.at(s.step);
    // Where the segment has this state: its start + (step - its step) x dt, to well within the
    // tolerance (the simulator's time is a sum of steps, the stamps are whole nanoseconds).
    const double expected = static_cast<double>(s.step - in.step) * dt;
    if (std::abs(secondsBetween(s.stamp, in.stamp) - expected) <= kSegmentTolerance) continue;
    if (!timeline.add(s.step, s.stamp)) return std::nullopt;  // steps only increase (readRun)
  }
  return timeline;
}

Status checkMeshMatches(const shape_msgs::Mesh& recorded, const Mesh& scene) {
  const std::string counts = std::to_string(recorded.vertices.size()) + " vertices, " +
                             std::to_string(recorded.triangles.size()) + " triangles";
  const std::string sceneCounts = std::to_string(scene.numVertices()) + " vertices, " +
                                  std::to_string(scene.numTriangles()) + " triangles";
  if (recorded.vertices.size() != static_cast<std::size_t>(scene.numVertices()) ||
      recorded.triangles.size() != scene.triangles.size()) {
    return Error{"the mesh stored in the bag (" + counts + ") is not the scene's mesh (" +
                 sceneCounts + ")"};
  }
  for (std::size_t t = 0; t < scene.triangles.size(); ++t) {
    for (int k = 0; k < 3; ++k) {
      if (recorded.triangles[t].vertex_indices[k] != static_cast<std::uint32_t>(scene.triangles[t][k])) {
        return Error{"the mesh stored in the bag differs from the scene's at triangle " +
                     std::to_string(t)};
      }
    }
  }
  const int d = scene.dim;
  for (Index i = 0; i < scene.numVertices(); ++i) {
    const auto& p = recorded.vertices[static_cast<std::size_t>(i)];
    const double c[3] = {p.x, p.y, p.z};
    for (int k = 0; k < d; ++k) {
      if (std::abs(c[k] - scene.restPositions[d * i + k]) > 1e-9) {
        return Error{"the mesh stored in the bag has vertex " + std::to_string(i) +
                     " at another rest position than the scene"};
      }
    }
  }
  return Status::success();
}

Expected<std::unique_ptr<RunWriter>> RunWriter::open(const std::string& path) {
  if (path.empty()) return std::unique_ptr<RunWriter>(new RunWriter(path, ""));
  Expected<std::string> temporary = createTemporaryNextTo(path);
  if (!temporary) return Error{temporary.error()};
  std::unique_ptr<RunWriter> writer(new RunWriter(path, *temporary));
  try {
    writer->bag_.open(writer->temporary_, rosbag::bagmode::Write);
  } catch (const rosbag::BagException& e) {
    return Error{"cannot write bag '" + path + "': " + e.what()};
  }
  return writer;
}

RunWriter::~RunWriter() {
  if (!closed_ && !path_.empty()) {
    try {
      bag_.close();
    } catch (const rosbag::BagException&) {
    }
    std::remove(temporary_.c_str());
  }
}

Status RunWriter::close() {
  if (path_.empty()) return Status::success();
  try {
    bag_.close();
  } catch (const rosbag::BagException& e) {
    return Error{"cannot finish bag '" + path_ + "': " + e.what()};
  }
  if (Status s = moveIntoPlace(temporary_, path_); !s) return s;
  closed_ = true;
  return Status::success();
}

}  // namespace fem_cloth
