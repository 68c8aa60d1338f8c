// IFC4 (ISO 16739-1), the open exchange format of building and plant models, as an ISO 10303-21
// (STEP) text file that BIM tools read for coordination and clash detection. Each element is a
// product contained in one IfcSite: a pipe (and a boundary joint, a pipe piece closing a gap) an
// IfcPipeSegment, an elbow an IfcPipeFitting BEND and a tee an IfcPipeFitting JUNCTION (the piece
// of its branch from the main's axis). Each is typed by its kind and nominal size (IfcPipeSegmentType with
// Pset_PipeSegmentTypeCommon's diameters, IfcPipeFittingType; the types declared in the project).
// Its body is an IfcSweptDiskSolid: a disk of its radius swept along its centre line, an
// IfcPolyline in metres. Each run is an IfcDistributionSystem grouping its elements, and each
// element carries the property set PipeRun_Element (confidence, review status, outside diameter,
// nominal size, length, bend radius and angle, run). GlobalIds are derived from each element's name
// and centre line: the same network exports the same ids.

#include "io/export_elements.h"

#include "piperun/pipe_measures.h"

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <map>
#include <string>
#include <tuple>
#include <vector>

namespace piperun::io {

namespace {

/// FNV-1a over bytes, continuing from `hash`.
std::uint64_t fnv1a(const void* data, std::size_t size, std::uint64_t hash) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < size; ++i) {
    hash ^= bytes[i];
    hash *= 0x100000001b3ULL;
  }
  return hash;
}

/// SplitMix64's finaliser: spreads a hash over all 64 bits.
std::uint64_t mixed(std::uint64_t x) {
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

constexpr std::uint64_t kFnvBasis = 0xcbf29ce484222325ULL;

/// A hash of `key` and `points`, continuing from `hash`.
std::uint64_t hashOf(const std::string& key, const std::vector<Eigen::Vector3d>& points, std::uint64_t hash) {
  hash = fnv1a(key.data(), key.size(), hash);
  for (const auto& p : points) hash = fnv1a(p.data(), 3 * sizeof(double), hash);
  return hash;
}

/// An IFC GlobalId: 128 bits written as 22 characters of IFC's base-64 alphabet (the first carries
/// 2 bits, the others 6 each), from a hash of `key` and `points`.
std::string globalId(const std::string& key, const std::vector<Eigen::Vector3d>& points) {
  static constexpr char kDigits[] = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz_$";
  const std::uint64_t hash = hashOf(key, points, kFnvBasis);
  const std::uint64_t high = mixed(hash), low = mixed(hash ^ 0x9e3779b97f4a7c15ULL);
  std::string id(22, '0');
  id[0] = kDigits[high >> 62];
  for (int i = 1; i < 22; ++i) {
    // Bits 125 - 6 (i - 1) down to 120 - 6 (i - 1) of the 128 (high then low).
    const int shift = 120 - 6 * (i - 1);
    const std::uint64_t digit = shift >= 64   ? (high >> (shift - 64)) & 63
                                : shift > 58 ? ((high << (64 - shift)) | (low >> shift)) & 63
                                             : (low >> shift) & 63;
    id[static_cast<std::size_t>(i)] = kDigits[digit];
  }
  return id;
}

/// A STEP string literal of UTF-8 `text`: apostrophes doubled, backslashes escaped, and each
/// character beyond ASCII (a file name's) as \X2\hhhh\X0\ (\X4\hhhhhhhh\X0\ beyond 16 bits), as
/// ISO 10303-21 has it; a byte that starts no UTF-8 character becomes '?'.
std::string stepString(const std::string& text) {
  std::string quoted = "'";
  for (std::size_t i = 0; i < text.size();) {
    const auto byte = static_cast<unsigned char>(text[i]);
    if (byte < 0x80) {
      if (byte == '\'' || byte == '\\') quoted += static_cast<char>(byte);
      quoted += static_cast<char>(byte);
      ++i;
      continue;
    }
    const std::size_t length = byte >= 0xF8 ? 0 : byte >= 0xF0 ? 4 : byte >= 0xE0 ? 3 : byte >= 0xC0 ? 2 : 0;
    bool whole = length > 0 && i + length <= text.size();
    std::uint32_t code = length > 0 ? byte & (0x7F >> length) : 0;
    for (std::size_t k = 1; whole && k < length; ++k) {
      const auto next = static_cast<unsigned char>(text[i + k]);
      whole = (next & 0xC0) == 0x80;
      code = (code << 6) | (next & 0x3F);
    }
    if (!whole) {
      quoted += '?';
      ++i;
      continue;
    }
    char hex[16];
    std::snprintf(hex, sizeof hex, code > 0xFFFF ? "\\X4\\%08X" : "\\X2\\%04X", code);
    quoted += hex;
    quoted += "\\X0\\";
    i += length;
  }
  return quoted + "'";
}

/// A STEP real: the shortest exact decimal, always with a point and an upper-case exponent.
std::string stepReal(double value) {
  std::string text = shortestNumber(value);
  const std::size_t exponent = text.find('e');
  std::string mantissa = text.substr(0, exponent);
  if (mantissa.find('.') == std::string::npos) mantissa += '.';
  return exponent == std::string::npos ? mantissa : mantissa + "E" + text.substr(exponent + 1);
}

/// The DATA section's instances, numbered as they are added.
class StepData {
 public:
  /// Adds `#n=ENTITY(arguments);` and returns "#n".
  std::string add(const std::string& entity, const std::string& arguments) {
    const std::string reference = "#" + std::to_string(++count_);
    text_ += reference + "=" + entity + "(" + arguments + ");\n";
    return reference;
  }
  const std::string& text() const { return text_; }

 private:
  int count_ = 0;
  std::string text_;
};

/// "(#1,#2,#3)".
std::string referenceList(const std::vector<std::string>& references) {
  std::string list = "(";
  for (std::size_t i = 0; i < references.size(); ++i) list += (i == 0 ? "" : ",") + references[i];
  return list + ")";
}

std::string point(const Eigen::Vector3d& p) {
  return "(" + stepReal(p.x()) + "," + stepReal(p.y()) + "," + stepReal(p.z()) + ")";
}

/// The IFC entity and predefined type of an element.
std::pair<const char*, const char*> productOf(ElementKind kind) {
  switch (kind) {
    case ElementKind::Elbow: return {"IFCPIPEFITTING", ".BEND."};
    case ElementKind::Tee: return {"IFCPIPEFITTING", ".JUNCTION."};
    case ElementKind::Pipe:
    case ElementKind::Boundary: break;
  }
  return {"IFCPIPESEGMENT", ".RIGIDSEGMENT."};
}

/// "2026-12-05T13:40:00", UTC.
std::string timestampNow() {
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%S", &utc);
  return text;
}

}  // namespace

std::string ifcDocument(const std::vector<ExportElement>& elements, const NominalSizes& sizes,
                        const std::string& fileName) {
  StepData data;
  const std::string origin = data.add("IFCCARTESIANPOINT", "(0.,0.,0.)");
  const std::string world = data.add("IFCAXIS2PLACEMENT3D", origin + ",$,$");
  const std::string model = data.add("IFCGEOMETRICREPRESENTATIONCONTEXT", "$,'Model',3,1.E-05," + world + ",$");
  const std::string body =
      data.add("IFCGEOMETRICREPRESENTATIONSUBCONTEXT", "'Body','Model',*,*,*,*," + model + ",$,.MODEL_VIEW.,$");
  const std::string metre = data.add("IFCSIUNIT", "*,.LENGTHUNIT.,$,.METRE.");
  const std::string radian = data.add("IFCSIUNIT", "*,.PLANEANGLEUNIT.,$,.RADIAN.");
  const std::string units = data.add("IFCUNITASSIGNMENT", referenceList({metre, radian}));
  // The ids of what the whole network has (project, site, runs) follow from every element's name
  // and centre line, so another network's differ.
  std::uint64_t networkHash = kFnvBasis;
  for (const auto& element : elements) networkHash = hashOf(element.name, element.axis, networkHash);
  const std::string network = std::to_string(networkHash);
  // A rooted instance: its GlobalId (from `key` and `points`), no owner history, then `rest`.
  const auto rooted = [&](const char* entity, const std::string& key, const std::vector<Eigen::Vector3d>& points,
                          const std::string& rest) {
    return data.add(entity, stepString(globalId(key, points)) + ",$," + rest);
  };
  const auto property = [&](const std::string& name, const std::string& value) {
    return data.add("IFCPROPERTYSINGLEVALUE", stepString(name) + ",$," + value + ",$");
  };

  const std::string project =
      rooted("IFCPROJECT", "project " + network, {}, "'PipeRun network',$,$,$,$,(" + model + ")," + units);
  const std::string sitePlacement = data.add("IFCLOCALPLACEMENT", "$," + world);
  const std::string site =
      rooted("IFCSITE", "site " + network, {}, "'Site',$,$," + sitePlacement + ",$,$,.ELEMENT.,$,$,$,$,$");
  rooted("IFCRELAGGREGATES", "aggregates " + network, {}, "$,$," + project + ",(" + site + ")");

  std::vector<std::string> products;
  std::map<int, std::vector<std::string>> productsOfRun;
  // The products of each type: a kind of segment or fitting in one nominal size.
  struct TypeKey {
    std::string entity, predefined;
    int dn = 0;
    bool operator<(const TypeKey& other) const {
      return std::tie(entity, predefined, dn) < std::tie(other.entity, other.predefined, other.dn);
    }
  };
  std::map<TypeKey, std::pair<NominalSize, std::vector<std::string>>> productsOfType;
  for (const auto& element : elements) {
    std::vector<std::string> vertices;
    for (const auto& p : element.axis) vertices.push_back(data.add("IFCCARTESIANPOINT", point(p)));
    const std::string line = data.add("IFCPOLYLINE", referenceList(vertices));
    const std::string solid = data.add("IFCSWEPTDISKSOLID", line + "," + stepReal(element.radius) + ",$,$,$");
    const std::string shape =
        data.add("IFCSHAPEREPRESENTATION", body + ",'Body','AdvancedSweptSolid',(" + solid + ")");
    const std::string definition = data.add("IFCPRODUCTDEFINITIONSHAPE", "$,$,(" + shape + ")");
    const std::string placement = data.add("IFCLOCALPLACEMENT", sitePlacement + "," + world);
    const auto [entity, predefined] = productOf(element.kind);
    const std::string product =
        rooted(entity, element.name, element.axis,
               stepString(element.name) + "," + stepString(kindName(element.kind)) + ",$," + placement + "," +
                   definition + "," + stepString(std::to_string(element.id)) + "," + predefined);
    products.push_back(product);
    if (element.runId >= 0) productsOfRun[element.runId].push_back(product);
    const NominalSize& size = sizes.nearest(element.radius);
    auto& ofType = productsOfType[TypeKey{std::string(entity), predefined, size.dn}];
    ofType.first = size;
    ofType.second.push_back(product);

    std::vector<std::string> properties = {
        property("Confidence", "IFCREAL(" + stepReal(element.confidence) + ")"),
        property("ReviewStatus", "IFCLABEL(" + stepString(element.status) + ")"),
        property("OutsideDiameter", "IFCPOSITIVELENGTHMEASURE(" + stepReal(2.0 * element.radius) + ")"),
        property("NominalSize", "IFCLABEL(" + stepString(size.nps + "\" DN " + std::to_string(size.dn)) + ")"),
        property("Length", "IFCLENGTHMEASURE(" + stepReal(element.length()) + ")")};
    if (element.kind == ElementKind::Elbow) {
      properties.push_back(property("BendRadius", "IFCPOSITIVELENGTHMEASURE(" + stepReal(element.bendRadius) + ")"));
      if (const auto bend = bendOf(element.axis)) {
        properties.push_back(property("BendAngle", "IFCPLANEANGLEMEASURE(" + stepReal(bend->angle) + ")"));
      }
    }
    if (element.runId >= 0) properties.push_back(property("Run", "IFCINTEGER(" + std::to_string(element.runId) + ")"));
    const std::string set = rooted("IFCPROPERTYSET", "properties " + element.name, element.axis,
                                   "'PipeRun_Element',$," + referenceList(properties));
    rooted("IFCRELDEFINESBYPROPERTIES", "defines " + element.name, element.axis,
           "$,$,(" + product + ")," + set);
  }
  if (!products.empty()) {
    rooted("IFCRELCONTAINEDINSPATIALSTRUCTURE", "contained " + network, {},
           "$,$," + referenceList(products) + "," + site);
  }
  // Each type: its name says what and which size ('pipe 8" DN 200', 'elbow 8" DN 200'); a segment
  // type carries its nominal and outside diameters in the standard Pset_PipeSegmentTypeCommon.
  std::vector<std::string> types;
  for (const auto& [key, sized] : productsOfType) {
    const auto& [size, members] = sized;
    const char* what = key.predefined == ".BEND." ? "elbow" : key.predefined == ".JUNCTION." ? "tee" : "pipe";
    const std::string name = std::string(what) + " " + size.nps + "\" DN " + std::to_string(size.dn);
    std::string propertySets = "$";
    if (key.entity == "IFCPIPESEGMENT") {
      propertySets = "(" +
                     rooted("IFCPROPERTYSET", "type properties " + name + " " + network, {},
                            "'Pset_PipeSegmentTypeCommon',$," +
                                referenceList({property("NominalDiameter", "IFCPOSITIVELENGTHMEASURE(" +
                                                                               stepReal(size.dn / 1000.0) + ")"),
                                               property("OuterDiameter", "IFCPOSITIVELENGTHMEASURE(" +
                                                                             stepReal(size.outsideDiameter) + ")")})) +
                     ")";
    }
    const std::string type = rooted((key.entity + "TYPE").c_str(), "type " + name + " " + network, {},
                                    stepString(name) + ",$,$," + propertySets + ",$,$,$," + key.predefined);
    types.push_back(type);
    rooted("IFCRELDEFINESBYTYPE", "typed " + name + " " + network, {}, "$,$," + referenceList(members) + "," + type);
  }
  if (!types.empty()) rooted("IFCRELDECLARES", "declares " + network, {}, "$,$," + project + "," + referenceList(types));
  for (const auto& [run, members] : productsOfRun) {
    const std::string name = "run " + std::to_string(run);
    const std::string key = name + " " + network;
    const std::string system = rooted("IFCDISTRIBUTIONSYSTEM", key, {}, stepString(name) + ",$,$,$,.NOTDEFINED.");
    rooted("IFCRELASSIGNSTOGROUP", "assigns " + key, {}, "$,$," + referenceList(members) + ",$," + system);
    rooted("IFCRELSERVICESBUILDINGS", "services " + key, {}, "$,$," + system + ",(" + site + ")");
  }

  return "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('ViewDefinition [ReferenceView_V1.2]'),'2;1');\n"
         "FILE_NAME(" +
         stepString(fileName) + "," + stepString(timestampNow()) +
         ",(''),(''),'PipeRun " PIPERUN_VERSION "','PipeRun " PIPERUN_VERSION "','');\n"
         "FILE_SCHEMA(('IFC4'));\nENDSEC;\nDATA;\n" +
         data.text() + "ENDSEC;\nEND-ISO-10303-21;\n";
}

}  // namespace piperun::io
