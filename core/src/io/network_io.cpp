#include "piperun/io/network_io.h"

#include "io/atomic_file.h"
#include "io/file_extension.h"
#include "io/network_json.h"
#include "json_text.h"
#include "piperun/error.h"

#include <nlohmann/json.hpp>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

namespace piperun {

using nlohmann::json;

namespace {

json pointToJson(const Eigen::Vector3d& p) { return json::array({p.x(), p.y(), p.z()}); }

json polylineToJson(const std::vector<Eigen::Vector3d>& points) {
  json array = json::array();
  for (const auto& p : points) array.push_back(pointToJson(p));
  return array;
}

// Reads values out of a parsed document, failing with the JSON pointer of the bad value.
class JsonReader {
 public:
  explicit JsonReader(const std::filesystem::path& source) : source_(source) {}

  [[noreturn]] void fail(const std::string& pointer, const std::string& message) const {
    throw InputError(source_, pointer.empty() ? "/" : pointer, message);
  }

  const json& member(const json& object, const std::string& pointer, const char* key) const {
    const auto found = object.find(key);
    if (found == object.end()) fail(pointer, std::string("missing required field \"") + key + "\"");
    return *found;
  }

  double number(const json& value, const std::string& pointer) const {
    if (!value.is_number()) fail(pointer, "expected a number");
    const double result = value.get<double>();
    if (!std::isfinite(result)) fail(pointer, "expected a finite number");
    return result;
  }

  int integer(const json& value, const std::string& pointer) const {
    if (!value.is_number_integer()) fail(pointer, "expected an integer");
    const auto result = value.get<std::int64_t>();
    if (result < std::numeric_limits<int>::min() || result > std::numeric_limits<int>::max()) {
      fail(pointer, "integer out of range");
    }
    return static_cast<int>(result);
  }

  std::string string(const json& value, const std::string& pointer) const {
    if (!value.is_string()) fail(pointer, "expected a string");
    return value.get<std::string>();
  }

  const json& array(const json& value, const std::string& pointer) const {
    if (!value.is_array()) fail(pointer, "expected an array");
    return value;
  }

  Eigen::Vector3d point(const json& value, const std::string& pointer) const {
    if (!value.is_array() || value.size() != 3) fail(pointer, "expected a point [x, y, z]");
    return {number(value[0], pointer + "/0"), number(value[1], pointer + "/1"), number(value[2], pointer + "/2")};
  }

  std::vector<Eigen::Vector3d> polyline(const json& value, const std::string& pointer) const {
    array(value, pointer);
    std::vector<Eigen::Vector3d> points;
    points.reserve(value.size());
    for (std::size_t i = 0; i < value.size(); ++i) points.push_back(point(value[i], pointer + "/" + std::to_string(i)));
    return points;
  }

  std::vector<int> ids(const json& value, const std::string& pointer) const {
    array(value, pointer);
    std::vector<int> result;
    result.reserve(value.size());
    for (std::size_t i = 0; i < value.size(); ++i) result.push_back(integer(value[i], pointer + "/" + std::to_string(i)));
    return result;
  }

  double optionalNumber(const json& object, const std::string& pointer, const char* key, double fallback) const {
    const auto found = object.find(key);
    return found == object.end() ? fallback : number(*found, pointer + "/" + key);
  }

 private:
  std::filesystem::path source_;
};

Pipe readPipe(const JsonReader& in, const json& object, const std::string& pointer) {
  if (!object.is_object()) in.fail(pointer, "expected a pipe object");
  Pipe pipe;
  pipe.id = in.integer(in.member(object, pointer, "id"), pointer + "/id");
  pipe.radius = in.number(in.member(object, pointer, "radius"), pointer + "/radius");
  if (!(pipe.radius > 0.0)) in.fail(pointer + "/radius", "expected a positive radius in metres");
  const auto axis = in.polyline(in.member(object, pointer, "axis"), pointer + "/axis");
  if (axis.size() != 2) in.fail(pointer + "/axis", "expected two points [start, end] for a pipe");
  pipe.start = axis[0];
  pipe.end = axis[1];
  pipe.fitRms = in.optionalNumber(object, pointer, "fit_rms", 0.0);
  pipe.confidence = in.optionalNumber(object, pointer, "confidence", 1.0);
  if (const auto found = object.find("inliers"); found != object.end()) {
    if (!found->is_number_integer() || found->get<std::int64_t>() < 0) {
      in.fail(pointer + "/inliers", "expected a non-negative integer");
    }
    pipe.inlierCount = found->get<std::int64_t>();
  }
  if (const auto found = object.find("run"); found != object.end() && !found->is_null()) {
    pipe.runId = in.integer(*found, pointer + "/run");
  }
  if (const auto found = object.find("status"); found != object.end()) {
    const auto status = pipeStatusFromString(in.string(*found, pointer + "/status"));
    if (!status) in.fail(pointer + "/status", "expected \"accepted\", \"proposed\" or \"deleted\"");
    pipe.status = *status;
  }
  return pipe;
}

Joint readJoint(const JsonReader& in, const json& object, const std::string& pointer) {
  if (!object.is_object()) in.fail(pointer, "expected a joint object");
  Joint joint;
  joint.id = in.integer(in.member(object, pointer, "id"), pointer + "/id");
  joint.radius = in.number(in.member(object, pointer, "radius"), pointer + "/radius");
  if (!(joint.radius > 0.0)) in.fail(pointer + "/radius", "expected a positive radius in metres");
  joint.axis = in.polyline(in.member(object, pointer, "axis"), pointer + "/axis");
  if (joint.axis.size() < 2) in.fail(pointer + "/axis", "expected at least two points");
  if (const auto found = object.find("type"); found != object.end()) {
    const auto type = jointTypeFromString(in.string(*found, pointer + "/type"));
    if (!type) in.fail(pointer + "/type", "expected \"elbow\", \"tee\" or \"boundary\"");
    joint.type = *type;
  } else {
    // Without a type, a curved axis can only be an elbow; a straight one closes a gap.
    joint.type = joint.axis.size() > 2 ? JointType::Elbow : JointType::Boundary;
  }
  if (const auto found = object.find("pipes"); found != object.end()) {
    joint.pipeIds = in.ids(*found, pointer + "/pipes");
  }
  joint.bendRadius = in.optionalNumber(object, pointer, "bend_radius", 0.0);
  joint.confidence = in.optionalNumber(object, pointer, "confidence", 1.0);
  if (const auto found = object.find("status"); found != object.end()) {
    const auto status = jointStatusFromString(in.string(*found, pointer + "/status"));
    if (!status) in.fail(pointer + "/status", "expected \"proposed\", \"accepted\" or \"rejected\"");
    joint.status = *status;
  }
  return joint;
}

Run readRun(const JsonReader& in, const json& object, const std::string& pointer) {
  if (!object.is_object()) in.fail(pointer, "expected a run object");
  Run run;
  run.id = in.integer(in.member(object, pointer, "id"), pointer + "/id");
  if (const auto found = object.find("pipes"); found != object.end()) run.pipeIds = in.ids(*found, pointer + "/pipes");
  if (const auto found = object.find("joints"); found != object.end()) run.jointIds = in.ids(*found, pointer + "/joints");
  return run;
}

}  // namespace

json pipeToJson(const Pipe& pipe) {
  json item;
  item["id"] = pipe.id;
  item["radius"] = pipe.radius;
  item["axis"] = polylineToJson({pipe.start, pipe.end});
  item["length"] = pipe.length();
  item["fit_rms"] = pipe.fitRms;
  item["inliers"] = pipe.inlierCount;
  item["confidence"] = pipe.confidence;
  item["run"] = pipe.runId >= 0 ? json(pipe.runId) : json(nullptr);
  item["status"] = toString(pipe.status);
  return item;
}

json jointToJson(const Joint& joint) {
  json item;
  item["id"] = joint.id;
  item["type"] = toString(joint.type);
  item["pipes"] = joint.pipeIds;
  item["radius"] = joint.radius;
  item["axis"] = polylineToJson(joint.axis);
  if (joint.type == JointType::Elbow) item["bend_radius"] = joint.bendRadius;
  item["confidence"] = joint.confidence;
  item["status"] = toString(joint.status);
  return item;
}

Pipe pipeFromJson(const json& object, const std::filesystem::path& source, const std::string& pointer) {
  return readPipe(JsonReader(source), object, pointer);
}

Joint jointFromJson(const json& object, const std::filesystem::path& source, const std::string& pointer) {
  return readJoint(JsonReader(source), object, pointer);
}

double runLength(const PipeNetwork& network, const Run& run) {
  double total = 0.0;
  for (int id : run.pipeIds) {
    if (const Pipe* pipe = network.findPipe(id)) total += pipe->length();
  }
  for (int id : run.jointIds) {
    if (const Joint* joint = network.findJoint(id)) total += joint->length();
  }
  return total;
}

double runNominalRadius(const PipeNetwork& network, const Run& run) {
  std::map<double, double> lengthByRadius;
  for (int id : run.pipeIds) {
    if (const Pipe* pipe = network.findPipe(id)) lengthByRadius[pipe->radius] += pipe->length();
  }
  for (int id : run.jointIds) {
    if (const Joint* joint = network.findJoint(id)) lengthByRadius[joint->radius] += joint->length();
  }
  double best = 0.0;
  double bestLength = -1.0;
  for (const auto& [radius, length] : lengthByRadius) {
    if (length > bestLength) {
      best = radius;
      bestLength = length;
    }
  }
  return best;
}

json networkToJsonValue(const PipeNetwork& network, const NetworkMetadata& metadata) {
  json document;
  document["format"] = kNetworkFormatName;
  document["version"] = kNetworkFormatVersion;
  document["units"] = "m";
  if (!metadata.empty()) document["metadata"] = metadata;

  json pipes = json::array();
  for (const auto& pipe : network.pipes) pipes.push_back(pipeToJson(pipe));
  document["pipes"] = std::move(pipes);

  json joints = json::array();
  for (const auto& joint : network.joints) joints.push_back(jointToJson(joint));
  document["joints"] = std::move(joints);

  json runs = json::array();
  for (const auto& run : network.runs) {
    json item;
    item["id"] = run.id;
    item["pipes"] = run.pipeIds;
    item["joints"] = run.jointIds;
    item["length"] = runLength(network, run);
    item["radius"] = runNominalRadius(network, run);
    runs.push_back(std::move(item));
  }
  document["runs"] = std::move(runs);
  return document;
}

std::string networkToJson(const PipeNetwork& network, const NetworkMetadata& metadata, int indent) {
  return networkToJsonValue(network, metadata).dump(indent) + "\n";
}

PipeNetwork networkFromJson(const std::string& text, const std::filesystem::path& source, NetworkMetadata* metadata) {
  return networkFromJsonValue(parseJsonText<json>(text, source), source, metadata);
}

PipeNetwork networkFromJsonValue(const json& document, const std::filesystem::path& source, NetworkMetadata* metadata) {
  const JsonReader in(source);
  if (!document.is_object()) in.fail("", "expected a JSON object with \"format\": \"piperun-network\"");
  const auto format = in.string(in.member(document, "", "format"), "/format");
  if (format != kNetworkFormatName) {
    in.fail("/format", "expected \"piperun-network\", found \"" + format + "\"");
  }
  const int version = in.integer(in.member(document, "", "version"), "/version");
  if (version != kNetworkFormatVersion) {
    in.fail("/version", "unsupported piperun-network version " + std::to_string(version) + "; this build reads version " +
                            std::to_string(kNetworkFormatVersion));
  }
  if (const auto found = document.find("units"); found != document.end()) {
    const auto units = in.string(*found, "/units");
    if (units != "m") in.fail("/units", "expected \"m\" (metres), found \"" + units + "\"");
  }

  PipeNetwork network;
  const json& pipes = in.array(in.member(document, "", "pipes"), "/pipes");
  for (std::size_t i = 0; i < pipes.size(); ++i) network.pipes.push_back(readPipe(in, pipes[i], "/pipes/" + std::to_string(i)));
  if (const auto found = document.find("joints"); found != document.end()) {
    const json& joints = in.array(*found, "/joints");
    for (std::size_t i = 0; i < joints.size(); ++i) {
      network.joints.push_back(readJoint(in, joints[i], "/joints/" + std::to_string(i)));
    }
  }
  if (const auto found = document.find("runs"); found != document.end()) {
    const json& runs = in.array(*found, "/runs");
    for (std::size_t i = 0; i < runs.size(); ++i) network.runs.push_back(readRun(in, runs[i], "/runs/" + std::to_string(i)));
  }
  try {
    network.validate();
  } catch (const std::invalid_argument& error) {
    in.fail("", error.what());
  }
  if (metadata) {
    metadata->clear();
    if (const auto found = document.find("metadata"); found != document.end() && found->is_object()) {
      for (const auto& [key, value] : found->items()) {
        (*metadata)[key] = value.is_string() ? value.get<std::string>() : value.dump();
      }
    }
  }
  return network;
}

void writeNetwork(const std::filesystem::path& path, const PipeNetwork& network, const NetworkMetadata& metadata) {
  io::writeFileAtomically(path, networkToJson(network, metadata));
}

bool isNetworkFile(const std::filesystem::path& path) { return io::lowerExtension(path) == ".json"; }

void recordUpAxis(NetworkMetadata& metadata, UpAxis up) {
  if (up != UpAxis::PlusZ) metadata["up"] = toString(up);
}

UpAxis recordedUpAxis(const NetworkMetadata& metadata, const std::filesystem::path& source) {
  const auto recorded = metadata.find("up");
  if (recorded == metadata.end()) return UpAxis::PlusZ;
  try {
    return upAxisFromString(recorded->second);
  } catch (const std::invalid_argument&) {
    throw InputError(source, "/metadata/up", "unknown up axis \"" + recorded->second + "\"");
  }
}

PipeNetwork readNetwork(const std::filesystem::path& path, NetworkMetadata* metadata) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) throw InputError(path, "", "no such file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", std::string("cannot open: ") + std::strerror(errno));
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return networkFromJson(buffer.str(), path, metadata);
}

}  // namespace piperun
