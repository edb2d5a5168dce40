#include "fem_cloth/ros/bag_io.h"

#include <rosbag/exceptions.h>
#include <rosbag/view.h>
#include <std_msgs/String.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <array>
#include <map>

#include "fem_cloth/ClothState.h"

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
    return Error{"topic " + c.topic + " holds " + c.datatype + " messages, expected " + type};
  }
  if (c.md5sum != md5) {
    return Error{"topic " + c.topic + " holds " + type +
                 " messages of another definition (md5 " + c.md5sum + ", this build " + md5 +
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

// A command message, sent or applied, into its topic's list (a sent one with a zero stamp is
// stamped with the time it was recorded: when the node took it).
void readCommand(const rosbag::MessageInstance& m, const RunTopics& topics,
                 std::array<std::vector<Command>, kCommandTopics>* sent,
                 std::array<std::vector<Command>, kCommandTopics>* applied) {
  forEachCommandType([&](auto type) {
    using C = typename decltype(type)::type;
    const CommandTopic topic = topicOf<C>();
    const std::size_t k = static_cast<std::size_t>(topic);
    const bool isSent = m.getTopic() == topics.sent(topic);
    if (!isSent && m.getTopic() != topics.applied(topic)) return;
    auto msg = m.instantiate<C>();
    if (!msg) return;
    C c = *msg;
    if (isSent && c.header.stamp.isZero()) c.header.stamp = m.getTime();
    (isSent ? *sent : *applied)[k].push_back(std::move(c));
  });
}

}  // namespace

Expected<YAML::Node> storedScene(const RecordedRun& run, const std::string& node) {
  if (run.sceneYaml.empty()) {
    return Error{"bag '" + run.path + "' holds no scene (" + RunTopics(node).scene +
                 "): record with launch/record.launch, or give the scene"};
  }
  try {
    return YAML::Load(run.sceneYaml);
  } catch (const YAML::Exception& e) {
    return Error{"the scene stored in bag '" + run.path + "' is not valid YAML: " + e.msg};
  }
}

Expected<RecordedRun> readRun(const std::string& path, const std::string& node) {
  if (!std::filesystem::exists(path)) return Error{"no bag at '" + path + "'"};
  const RunTopics topics(node);
  RecordedRun run;
  run.path = path;
  rosbag::Bag bag;
  try {
    bag.open(path, rosbag::bagmode::Read);
  } catch (const rosbag::BagUnindexedException&) {
    return Error{"bag '" + path + "' is truncated or was not closed (no index): "
                 "'rosbag reindex' may recover what it holds"};
  } catch (const rosbag::BagIOException& e) {
    // Reading past the end of the file: the index the header points to is missing.
    return Error{"bag '" + path + "' is truncated or damaged (" + e.what() +
                 "): 'rosbag reindex' may recover what it holds"};
  } catch (const rosbag::BagException& e) {
    return Error{"cannot read bag '" + path + "': " + e.what()};
  }
  try {
    rosbag::View view(bag);
    run.begin = view.getBeginTime();
    run.end = view.getEndTime();
    if (Status s = checkTypes(view, topics); !s) return Error{"bag '" + path + "': " + s.error()};
    const double span = std::max((run.end - run.begin).toSec(), 0.0);
    run.tf = std::make_shared<tf2::BufferCore>(ros::Duration(span + 60.0));
    std::array<std::vector<Command>, kCommandTopics> sent, applied;
    for (const rosbag::MessageInstance& m : view) {
      const std::string& topic = m.getTopic();
      if (topic == topics.scene) {
        if (auto msg = m.instantiate<std_msgs::String>()) run.sceneYaml = msg->data;
      } else if (topic == topics.mesh) {
        if (auto msg = m.instantiate<shape_msgs::Mesh>(); msg && !run.mesh) run.mesh = *msg;
      } else if (topic == topics.state) {
        if (auto msg = m.instantiate<ClothState>()) {
          if (run.frame.empty()) run.frame = msg->header.frame_id;
          run.states.push_back({msg->step, msg->header.stamp, msg->state_hash});
        }
      } else if (topic == "/tf" || topic == "/tf_static") {
        if (auto msg = m.instantiate<tf2_msgs::TFMessage>()) {
          for (const auto& t : msg->transforms) run.tf->setTransform(t, "bag", topic == "/tf_static");
        }
      } else {
        readCommand(m, topics, &sent, &applied);
      }
    }
    bool anyApplied = false, anySent = false;
    for (std::size_t k = 0; k < kCommandTopics; ++k) {
      anyApplied = anyApplied || !applied[k].empty();
      anySent = anySent || !sent[k].empty();
    }
    run.exactCommands = anyApplied || !anySent;
    for (std::vector<Command>& topic : run.exactCommands ? applied : sent) {
      for (Command& c : topic) run.commands.push_back(std::move(c));
    }
  } catch (const rosbag::BagException& e) {
    return Error{"bag '" + path + "' is truncated or damaged: " + e.what()};
  }
  return run;
}

std::optional<ros::Time> runEpoch(const RecordedRun& run, double dt) {
  if (run.states.empty()) return std::nullopt;
  const RecordedState& s = run.states.front();
  return s.stamp - ros::Duration(static_cast<double>(s.step) * dt);
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
  std::unique_ptr<RunWriter> writer(new RunWriter(path));
  if (path.empty()) return writer;
  try {
    writer->bag_.open(path + ".partial", rosbag::bagmode::Write);
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
    std::remove((path_ + ".partial").c_str());
  }
}

Status RunWriter::close() {
  if (path_.empty()) return Status::success();
  try {
    bag_.close();
  } catch (const rosbag::BagException& e) {
    return Error{"cannot finish bag '" + path_ + "': " + e.what()};
  }
  std::error_code ec;
  std::filesystem::rename(path_ + ".partial", path_, ec);
  if (ec) return Error{"cannot rename '" + path_ + ".partial' to '" + path_ + "': " + ec.message()};
  closed_ = true;
  return Status::success();
}

}  // namespace fem_cloth
