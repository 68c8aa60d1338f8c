// Tests of the network exports: every format is written, read back (OBJ and PLY with VTK's
// readers, CSV, DXF, PCF and IFC with the small parsers below) and its geometry compared with the
// network.

#include <gtest/gtest.h>

#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkDataArray.h>
#include <vtkIdList.h>
#include <vtkNew.h>
#include <vtkOBJReader.h>
#include <vtkPLYReader.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "piperun/error.h"
#include "piperun/io/network_export.h"
#include "synth/scene_layout.h"
#include "test_util.h"

namespace piperun {
namespace {

using Eigen::Vector3d;
using test::makePipe;
using test::TempDir;

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180.0;
constexpr double kMainRadius = 0.05;
constexpr double kBendRadius = 0.15;
constexpr double kBranchRadius = 0.03;

Joint makeJoint(int id, JointType type, std::vector<int> pipes, double radius, std::vector<Vector3d> axis,
                JointStatus status = JointStatus::Accepted) {
  Joint joint;
  joint.id = id;
  joint.type = type;
  joint.pipeIds = std::move(pipes);
  joint.radius = radius;
  joint.axis = std::move(axis);
  joint.status = status;
  joint.confidence = 0.7;
  return joint;
}

// A run of a main pipe along x with a tee (branch down) and a 90° elbow into y; beside it a pipe in
// no run, two pipes joined by a boundary joint, a deleted pipe and a rejected joint. Pipe and joint
// ids overlap on purpose: they are separate id spaces.
PipeNetwork sampleNetwork() {
  PipeNetwork network;
  const auto addPipe = [&](int id, double radius, Vector3d start, Vector3d end, int run,
                           PipeStatus status = PipeStatus::Accepted) {
    network.pipes.push_back(makePipe(id, radius, start, end, run, status));
  };
  addPipe(1, kMainRadius, {0, 0, 1}, {2, 0, 1}, 0);
  addPipe(2, kMainRadius, {2 + kBendRadius, kBendRadius, 1}, {2 + kBendRadius, 1.5, 1}, 0);
  addPipe(3, kBranchRadius, {1, 0, 1 - kMainRadius}, {1, 0, 0.2}, 0);
  addPipe(4, 0.04, {5, 5, 5}, {6, 5, 5}, -1, PipeStatus::Deleted);
  addPipe(5, kMainRadius, {2 + kBendRadius, 1.6, 1}, {2 + kBendRadius, 2.5, 1}, -1);
  addPipe(6, 0.02, {3, 3, 0}, {4, 3, 0}, -1);
  addPipe(7, 0.02, {4.1, 3, 0}, {5, 3, 0}, -1, PipeStatus::Proposed);

  const auto addJoint = [&](int id, JointType type, std::vector<int> pipes, double radius,
                            std::vector<Vector3d> axis, JointStatus status) {
    network.joints.push_back(makeJoint(id, type, std::move(pipes), radius, std::move(axis), status));
    if (type == JointType::Elbow) network.joints.back().bendRadius = kBendRadius;
  };
  addJoint(1, JointType::Elbow, {1, 2}, kMainRadius,
           sampleArc({2, kBendRadius, 1}, {2, 0, 1}, {2 + kBendRadius, kBendRadius, 1}, 0.01), JointStatus::Accepted);
  addJoint(2, JointType::Tee, {1, 3}, kBranchRadius, {{1, 0, 1}, {1, 0, 1 - kMainRadius}}, JointStatus::Accepted);
  addJoint(3, JointType::Boundary, {2, 5}, kMainRadius, {{2 + kBendRadius, 1.5, 1}, {2 + kBendRadius, 1.6, 1}},
           JointStatus::Rejected);
  addJoint(4, JointType::Boundary, {6, 7}, 0.02, {{4, 3, 0}, {4.1, 3, 0}}, JointStatus::Proposed);
  network.runs.push_back({0, {1, 2, 3}, {1, 2}});
  network.validate();
  return network;
}

/// `network` moved by `offset`.
PipeNetwork shifted(PipeNetwork network, const Vector3d& offset) {
  for (Pipe& pipe : network.pipes) {
    pipe.start += offset;
    pipe.end += offset;
  }
  for (Joint& joint : network.joints) {
    for (Vector3d& point : joint.axis) point += offset;
  }
  return network;
}

/// The sample network turned so that `up` is its up axis, and export options that say so.
std::pair<PipeNetwork, ExportOptions> turnedSample(UpAxis up) {
  PipeNetwork turned = sampleNetwork();
  turned.turn(turnZUpTo(up));
  ExportOptions options;
  options.up = up;
  return {turned, options};
}

const std::set<std::string> kExportedNames = {"pipe-1", "pipe-2", "pipe-3",  "pipe-5",    "pipe-6",
                                              "pipe-7", "elbow-1", "tee-2", "boundary-4"};

std::vector<std::string> splitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    lines.push_back(line);
  }
  return lines;
}

std::vector<std::string> splitWords(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> words;
  for (std::string word; in >> word;) words.push_back(word);
  return words;
}

std::vector<std::string> splitFields(const std::string& line) {
  std::vector<std::string> fields;
  std::size_t begin = 0;
  for (std::size_t comma; (comma = line.find(',', begin)) != std::string::npos; begin = comma + 1) {
    fields.push_back(line.substr(begin, comma - begin));
  }
  fields.push_back(line.substr(begin));
  return fields;
}

// ---------------------------------------------------------------------------------------------
// Meshes

// The triangles of one element of a mesh read back by VTK, with the checks every closed tube passes.
struct MeshPart {
  std::vector<std::array<vtkIdType, 3>> triangles;
  Vector3d low = Vector3d::Constant(1e300);
  Vector3d high = Vector3d::Constant(-1e300);
  double volume = 0.0;  // signed: positive when the triangles face outwards

  void add(vtkPolyData* mesh, const vtkIdType* ids) {
    std::array<Vector3d, 3> corners;
    for (int c = 0; c < 3; ++c) {
      double p[3];
      mesh->GetPoint(ids[c], p);
      corners[c] = {p[0], p[1], p[2]};
      low = low.cwiseMin(corners[c]);
      high = high.cwiseMax(corners[c]);
    }
    triangles.push_back({ids[0], ids[1], ids[2]});
    volume += corners[0].dot(corners[1].cross(corners[2])) / 6.0;
  }

  // Closed and consistently oriented: every directed edge appears once and its reverse once.
  bool closedAndOriented() const {
    std::map<std::pair<vtkIdType, vtkIdType>, int> edges;
    for (const auto& t : triangles) {
      for (int c = 0; c < 3; ++c) ++edges[{t[c], t[(c + 1) % 3]}];
    }
    for (const auto& [edge, count] : edges) {
      const auto reverse = edges.find({edge.second, edge.first});
      if (count != 1 || reverse == edges.end() || reverse->second != 1) return false;
    }
    return !triangles.empty();
  }
};

// Splits a VTK mesh into parts by a per-cell integer array.
std::map<int, MeshPart> partsByCellArray(vtkPolyData* mesh, const char* arrayName) {
  std::map<int, MeshPart> parts;
  vtkDataArray* labels = mesh->GetCellData()->GetArray(arrayName);
  if (!labels) return parts;
  vtkCellArray* polys = mesh->GetPolys();
  vtkNew<vtkIdList> ids;
  for (vtkIdType cell = 0; cell < mesh->GetNumberOfPolys(); ++cell) {
    polys->GetCellAtId(cell, ids);
    if (ids->GetNumberOfIds() != 3) continue;
    parts[static_cast<int>(labels->GetTuple1(cell))].add(mesh, ids->GetPointer(0));
  }
  return parts;
}

// Volume of a straight tube of `sides` sides: the regular polygon's area times the length.
double prismVolume(double radius, int sides, double length) {
  return 0.5 * sides * radius * radius * std::sin(2.0 * kPi / sides) * length;
}

void expectBounds(const MeshPart& part, const Vector3d& low, const Vector3d& high, double tolerance) {
  EXPECT_LT((part.low - low).norm(), tolerance) << part.low.transpose() << " vs " << low.transpose();
  EXPECT_LT((part.high - high).norm(), tolerance) << part.high.transpose() << " vs " << high.transpose();
}

TEST(Export, FormatNamesAndExtensions) {
  for (ExportFormat format :
       {ExportFormat::Obj, ExportFormat::Ply, ExportFormat::Csv, ExportFormat::Dxf, ExportFormat::Pcf, ExportFormat::Ifc}) {
    EXPECT_EQ(exportFormatFromString(toString(format)), format);
    EXPECT_EQ(exportFormatFromPath("out/net." + toString(format)), format);
  }
  EXPECT_EQ(exportFormatFromString("PCF"), ExportFormat::Pcf);
  EXPECT_EQ(exportFormatFromPath("NET.DXF"), ExportFormat::Dxf);
  EXPECT_FALSE(exportFormatFromString("stl"));
  EXPECT_FALSE(exportFormatFromPath("net.json"));
  EXPECT_FALSE(exportFormatFromPath("net"));
  EXPECT_EQ(exportFormatNames(), (std::vector<std::string>{"obj", "ply", "csv", "dxf", "pcf", "ifc"}));
  EXPECT_EQ(exportFileKinds(), ".obj .ply .csv .dxf .pcf or .ifc");
}

TEST(Export, SegmentsGrowWithRadiusInFours) {
  const ExportOptions options;
  int previous = 0;
  for (double radius : {0.005, 0.02, 0.05, 0.2, 0.5, 2.0}) {
    const int segments = meshSegments(radius, options);
    EXPECT_EQ(segments % 4, 0) << radius;
    EXPECT_GE(segments, previous) << radius;
    EXPECT_GE(segments, options.minSegments);
    EXPECT_LE(segments, options.maxSegments);
    // Within the clamp, the polygon stays within the chord tolerance.
    if (segments < options.maxSegments) {
      EXPECT_LE(radius * (1.0 - std::cos(kPi / segments)), options.chordTolerance);
    }
    previous = segments;
  }
  EXPECT_GT(meshSegments(0.5, options), meshSegments(0.05, options));
  EXPECT_EQ(meshSegments(1e-4, options), options.minSegments);
  EXPECT_EQ(meshSegments(100.0, options), options.maxSegments);
}

TEST(Export, ObjReadBackByVtk) {
  TempDir dir;
  const auto path = dir / "net.obj";
  const ExportOptions options;
  exportNetwork(sampleNetwork(), ExportFormat::Obj, path, options);

  // Object and group names, in file order.
  std::vector<std::string> groups;
  std::set<std::string> objects;
  std::size_t vertexLines = 0, faceLines = 0;
  for (const auto& line : splitLines(test::readFile(path))) {
    const auto words = splitWords(line);
    if (words.empty()) continue;
    if (words[0] == "g") groups.push_back(words.at(1));
    if (words[0] == "o") objects.insert(words.at(1));
    vertexLines += words[0] == "v";
    faceLines += words[0] == "f";
  }
  EXPECT_EQ(std::set<std::string>(groups.begin(), groups.end()), kExportedNames);
  EXPECT_EQ(objects, kExportedNames);
  ASSERT_EQ(groups.size(), kExportedNames.size());

  vtkNew<vtkOBJReader> reader;
  reader->SetFileName(path.c_str());
  reader->Update();
  vtkPolyData* mesh = reader->GetOutput();
  EXPECT_EQ(static_cast<std::size_t>(mesh->GetNumberOfPoints()), vertexLines);
  EXPECT_EQ(static_cast<std::size_t>(mesh->GetNumberOfPolys()), faceLines);
  const auto parts = partsByCellArray(mesh, "GroupIds");
  ASSERT_EQ(parts.size(), groups.size());
  std::map<std::string, const MeshPart*> byName;
  for (const auto& [group, part] : parts) byName[groups.at(group)] = &part;

  for (const auto& [name, part] : byName) {
    EXPECT_TRUE(part->closedAndOriented()) << name;
    EXPECT_GT(part->volume, 0.0) << name;
  }
  // The main pipe: bounds exactly the cylinder's (an axis-aligned tube reaches ±r), volume of its prism.
  const MeshPart& main = *byName.at("pipe-1");
  expectBounds(main, {0, -kMainRadius, 1 - kMainRadius}, {2, kMainRadius, 1 + kMainRadius}, 1e-6);
  const int sides = meshSegments(kMainRadius, options);
  EXPECT_NEAR(main.volume, prismVolume(kMainRadius, sides, 2.0), 1e-6);
  EXPECT_EQ(main.triangles.size(), static_cast<std::size_t>(4 * sides));
  // The elbow: a quarter torus section around (2, 0.15, 1) from -y to +x, its end rings square to
  // the pipes, so its bounds are the torus section's.
  const MeshPart& elbow = *byName.at("elbow-1");
  expectBounds(elbow, {2, -kMainRadius, 1 - kMainRadius},
               {2 + kBendRadius + kMainRadius, kBendRadius, 1 + kMainRadius}, 1e-5);
  EXPECT_NEAR(elbow.volume, prismVolume(kMainRadius, sides, 0.5 * kPi * kBendRadius), 0.01 * elbow.volume);
  // The deleted pipe (around y = z = 5) is not in the mesh.
  double bounds[6];
  mesh->GetBounds(bounds);
  EXPECT_LT(bounds[3], 3.1);
  EXPECT_LT(bounds[5], 1.1);
}

TEST(Export, PlyReadBackByVtkWithElementIds) {
  TempDir dir;
  const auto objPath = dir / "net.obj";
  const auto plyPath = dir / "net.ply";
  const PipeNetwork network = sampleNetwork();
  exportNetwork(network, ExportFormat::Obj, objPath);
  exportNetwork(network, ExportFormat::Ply, plyPath);

  vtkNew<vtkOBJReader> objReader;
  objReader->SetFileName(objPath.c_str());
  objReader->Update();
  vtkNew<vtkPLYReader> plyReader;
  plyReader->SetFileName(plyPath.c_str());
  plyReader->Update();
  vtkPolyData* ply = plyReader->GetOutput();
  // The same mesh as the OBJ export.
  EXPECT_EQ(ply->GetNumberOfPoints(), objReader->GetOutput()->GetNumberOfPoints());
  EXPECT_EQ(ply->GetNumberOfPolys(), objReader->GetOutput()->GetNumberOfPolys());
  double plyBounds[6], objBounds[6];
  ply->GetBounds(plyBounds);
  objReader->GetOutput()->GetBounds(objBounds);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(plyBounds[i], objBounds[i], 1e-6);

  // The per-face element id and type, read straight from the binary body.
  const std::string bytes = test::readFile(plyPath);
  const auto headerEnd = bytes.find("end_header\n");
  ASSERT_NE(headerEnd, std::string::npos);
  const std::string header = bytes.substr(0, headerEnd);
  EXPECT_NE(header.find("format binary_little_endian 1.0"), std::string::npos);
  EXPECT_NE(header.find("property float x"), std::string::npos);
  EXPECT_NE(header.find("element face " + std::to_string(ply->GetNumberOfPolys()) +
                        "\nproperty list uchar int vertex_indices\nproperty int element_id\nproperty uchar element_type\n"),
            std::string::npos);
  const char* body = bytes.data() + headerEnd + std::strlen("end_header\n");
  const char* faces = body + ply->GetNumberOfPoints() * 3 * sizeof(float);
  constexpr std::size_t kFaceBytes = 1 + 3 * 4 + 4 + 1;
  ASSERT_EQ(bytes.size(), static_cast<std::size_t>(faces - bytes.data()) + ply->GetNumberOfPolys() * kFaceBytes);
  std::map<std::pair<int, int>, MeshPart> parts;  // (type, id) → faces
  for (vtkIdType f = 0; f < ply->GetNumberOfPolys(); ++f) {
    const char* face = faces + f * kFaceBytes;
    ASSERT_EQ(static_cast<unsigned char>(face[0]), 3u);
    std::int32_t corners[3], id;
    std::memcpy(corners, face + 1, sizeof corners);
    std::memcpy(&id, face + 13, sizeof id);
    const int type = static_cast<unsigned char>(face[17]);
    const vtkIdType ids[3] = {corners[0], corners[1], corners[2]};
    parts[{type, id}].add(ply, ids);
  }
  const std::set<std::pair<int, int>> expected = {{0, 1}, {0, 2}, {0, 3}, {0, 5}, {0, 6},
                                                  {0, 7}, {1, 1}, {2, 2}, {3, 4}};
  std::set<std::pair<int, int>> found;
  for (const auto& [key, part] : parts) {
    found.insert(key);
    EXPECT_TRUE(part.closedAndOriented()) << key.first << " " << key.second;
  }
  EXPECT_EQ(found, expected);
  expectBounds(parts.at({0, 1}), {0, -kMainRadius, 1 - kMainRadius}, {2, kMainRadius, 1 + kMainRadius}, 1e-6);
  // The tee's mesh is its branch piece: from the main axis down to the branch pipe, of the branch radius.
  expectBounds(parts.at({2, 2}), {1 - kBranchRadius, -kBranchRadius, 1 - kMainRadius}, {1 + kBranchRadius, kBranchRadius, 1},
               1e-6);
}

TEST(Export, PlyFarFromOriginStoresDoubles) {
  const Vector3d offset(500000.0, 4000000.0, 0.0);
  const PipeNetwork network = shifted(sampleNetwork(), offset);
  TempDir dir;
  exportNetwork(network, ExportFormat::Ply, dir / "far.ply");
  vtkNew<vtkPLYReader> reader;
  reader->SetFileName((dir / "far.ply").c_str());
  reader->Update();
  const std::string bytes = test::readFile(dir / "far.ply");
  EXPECT_NE(bytes.find("property double x"), std::string::npos);
  // The first vertex of pipe 1 is on its start circle, to the micrometre.
  const auto body = bytes.find("end_header\n") + std::strlen("end_header\n");
  double first[3];
  std::memcpy(first, bytes.data() + body, sizeof first);
  EXPECT_NEAR((Vector3d(first[0], first[1], first[2]) - (offset + Vector3d(0, 0, 1))).norm(), kMainRadius, 1e-6);
  EXPECT_GT(reader->GetOutput()->GetNumberOfPolys(), 0);
}

// ---------------------------------------------------------------------------------------------
// CSV

TEST(Export, CsvOneRowPerElement) {
  TempDir dir;
  exportNetwork(sampleNetwork(), ExportFormat::Csv, dir / "net.csv");
  const std::string text = test::readFile(dir / "net.csv");
  // RFC 4180 line ends.
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), std::count(text.begin(), text.end(), '\r'));
  const auto lines = splitLines(text);
  ASSERT_EQ(lines.size(), 1 + kExportedNames.size());
  EXPECT_EQ(lines[0],
            "id,type,run,radius_m,length_m,start_x,start_y,start_z,end_x,end_y,end_z,bend_radius_m,confidence,status,nps,dn,"
            "lowest_m,highest_m,slope_deg,bend_angle_deg");
  std::map<std::string, std::vector<std::string>> rows;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    auto fields = splitFields(lines[i]);
    ASSERT_EQ(fields.size(), 20u) << lines[i];
    rows[fields[1] + "-" + fields[0]] = fields;
  }
  std::set<std::string> names;
  for (const auto& [name, row] : rows) names.insert(name);
  EXPECT_EQ(names, kExportedNames);

  const auto& elbow = rows.at("elbow-1");
  EXPECT_EQ(elbow[2], "0");
  EXPECT_DOUBLE_EQ(std::stod(elbow[3]), kMainRadius);
  EXPECT_NEAR(std::stod(elbow[4]), 0.5 * kPi * kBendRadius, 1e-4);
  EXPECT_DOUBLE_EQ(std::stod(elbow[5]), 2.0);
  EXPECT_DOUBLE_EQ(std::stod(elbow[8]), 2 + kBendRadius);
  EXPECT_DOUBLE_EQ(std::stod(elbow[9]), kBendRadius);
  EXPECT_DOUBLE_EQ(std::stod(elbow[10]), 1.0);
  EXPECT_DOUBLE_EQ(std::stod(elbow[11]), kBendRadius);
  EXPECT_EQ(elbow[13], "accepted");

  const auto& main = rows.at("pipe-1");
  EXPECT_DOUBLE_EQ(std::stod(main[4]), 2.0);
  EXPECT_EQ(main[11], "");  // bend radius only for elbows
  EXPECT_DOUBLE_EQ(std::stod(main[12]), 0.9);
  EXPECT_EQ(rows.at("pipe-5")[2], "");  // in no run
  EXPECT_EQ(rows.at("boundary-4")[13], "proposed");
  EXPECT_EQ(rows.at("pipe-7")[13], "proposed");
  EXPECT_EQ(rows.at("tee-2")[2], "0");
  // The nominal size nearest each radius: 100 mm outside is 3-1/2" (101.6).
  EXPECT_EQ(main[14], "3-1/2");
  EXPECT_EQ(main[15], "90");
  EXPECT_EQ(rows.at("tee-2")[14], "2");  // the branch's 60 mm: 2" (60.3)
  EXPECT_EQ(rows.at("tee-2")[15], "50");

  // Heights along z the tubes reach: the level main's bottom and top of pipe, the branch riser's
  // end faces; a straight piece's slope.
  const auto heights = [&](const std::string& name) {
    const auto& row = rows.at(name);
    return std::array<std::string, 3>{row[16], row[17], row[18]};
  };
  EXPECT_DOUBLE_EQ(std::stod(heights("pipe-1")[0]), 1 - kMainRadius);
  EXPECT_DOUBLE_EQ(std::stod(heights("pipe-1")[1]), 1 + kMainRadius);
  EXPECT_EQ(heights("pipe-1")[2], "0");
  EXPECT_DOUBLE_EQ(std::stod(heights("pipe-3")[0]), 0.2);
  EXPECT_DOUBLE_EQ(std::stod(heights("pipe-3")[1]), 1 - kMainRadius);
  EXPECT_EQ(heights("pipe-3")[2], "90");
  EXPECT_NEAR(std::stod(heights("elbow-1")[0]), 1 - kMainRadius, 1e-12);
  EXPECT_NEAR(std::stod(heights("elbow-1")[1]), 1 + kMainRadius, 1e-12);
  EXPECT_EQ(heights("elbow-1")[2], "");  // no slope for a bend...
  EXPECT_EQ(heights("tee-2")[2], "");    // ...nor a tee
  EXPECT_EQ(heights("boundary-4")[2], "0");
  // An elbow's angle, from the circle through its arc; none for the others.
  EXPECT_NEAR(std::stod(rows.at("elbow-1")[19]), 90.0, 1e-9);
  EXPECT_EQ(rows.at("pipe-1")[19], "");
  EXPECT_EQ(rows.at("tee-2")[19], "");
}

TEST(Export, CsvHeightsAreAlongTheNetworksUpAxis) {
  // The sample network turned so that y is up, and told so: its heights are the z-up network's
  // (its co-ordinates stay the scan's).
  TempDir dir;
  exportNetwork(sampleNetwork(), ExportFormat::Csv, dir / "z.csv");
  const auto [turned, options] = turnedSample(UpAxis::PlusY);
  exportNetwork(turned, ExportFormat::Csv, dir / "y.csv", options);
  const auto z = splitLines(test::readFile(dir / "z.csv")), y = splitLines(test::readFile(dir / "y.csv"));
  ASSERT_EQ(z.size(), y.size());
  for (std::size_t i = 1; i < z.size(); ++i) {
    const auto zFields = splitFields(z[i]), yFields = splitFields(y[i]);
    for (std::size_t column = 16; column < 20; ++column) {
      if (zFields[column].empty()) {
        EXPECT_EQ(yFields[column], "") << z[i];
      } else {
        EXPECT_NEAR(std::stod(yFields[column]), std::stod(zFields[column]), 1e-12) << z[i];
      }
    }
    EXPECT_NE(zFields[7], yFields[7]);  // start_z: the co-ordinates are turned's
  }
}

// ---------------------------------------------------------------------------------------------
// DXF

struct DxfPolyline {
  std::string layer;
  int flags = 0;
  std::vector<std::string> xdataStrings;
  std::vector<double> xdataReals;
  std::vector<long> xdataIntegers;
  std::string application;
  std::vector<Vector3d> vertices;
};

struct DxfFile {
  std::map<std::string, std::string> header;  // variable → first value
  std::set<std::string> layers;
  std::set<std::string> applications;
  std::vector<DxfPolyline> polylines;
  bool endsWithEof = false;
};

// Reads the (group code, value) pairs of an ASCII DXF and collects what the export writes.
DxfFile parseDxf(const std::string& text) {
  const auto lines = splitLines(text);
  std::vector<std::pair<int, std::string>> pairs;
  for (std::size_t i = 0; i + 1 < lines.size(); i += 2) pairs.emplace_back(std::stoi(lines[i]), lines[i + 1]);
  DxfFile dxf;
  std::string section, table, entity;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const auto& [code, value] = pairs[i];
    if (code == 0) {
      entity = value;
      if (value == "EOF") dxf.endsWithEof = i + 1 == pairs.size();
      if (value == "POLYLINE") dxf.polylines.emplace_back();
      if (value == "VERTEX") dxf.polylines.back().vertices.emplace_back(Vector3d::Zero());
      if (value == "ENDSEC") section.clear();
      continue;
    }
    if (code == 2 && entity == "SECTION") section = value;
    if (code == 2 && entity == "TABLE") table = value;
    if (section == "HEADER" && code == 9) dxf.header[value] = pairs.at(i + 1).second;
    if (code == 2 && entity == "LAYER") dxf.layers.insert(value);
    if (code == 2 && entity == "APPID") dxf.applications.insert(value);
    if (entity == "POLYLINE") {
      auto& polyline = dxf.polylines.back();
      if (code == 8) polyline.layer = value;
      if (code == 70) polyline.flags = std::stoi(value);
      if (code == 1001) polyline.application = value;
      if (code == 1000) polyline.xdataStrings.push_back(value);
      if (code == 1040) polyline.xdataReals.push_back(std::stod(value));
      if (code == 1071) polyline.xdataIntegers.push_back(std::stol(value));
    }
    if (entity == "VERTEX" && code >= 10 && code <= 30 && code % 10 == 0) {
      dxf.polylines.back().vertices.back()[code / 10 - 1] = std::stod(value);
    }
  }
  return dxf;
}

TEST(Export, DxfPolylinesWithRadiusInXdata) {
  TempDir dir;
  const PipeNetwork network = sampleNetwork();
  exportNetwork(network, ExportFormat::Dxf, dir / "net.dxf");
  const DxfFile dxf = parseDxf(test::readFile(dir / "net.dxf"));
  EXPECT_EQ(dxf.header.at("$ACADVER"), "AC1009");
  EXPECT_EQ(dxf.header.at("$INSUNITS"), "6");  // metres
  EXPECT_EQ(dxf.header.at("$MEASUREMENT"), "1");
  EXPECT_TRUE(dxf.endsWithEof);
  EXPECT_EQ(dxf.applications, std::set<std::string>{"PIPERUN"});
  EXPECT_EQ(dxf.layers, (std::set<std::string>{"PIPE", "ELBOW", "TEE", "BOUNDARY"}));

  std::map<std::string, const DxfPolyline*> byName;
  for (const auto& polyline : dxf.polylines) {
    ASSERT_EQ(polyline.application, "PIPERUN");
    ASSERT_EQ(polyline.xdataStrings.size(), 2u);  // name, status
    ASSERT_EQ(polyline.xdataReals.size(), 3u);    // radius, bend radius, confidence
    ASSERT_EQ(polyline.xdataIntegers.size(), 1u); // run
    EXPECT_EQ(polyline.flags, 8);                 // 3-D polyline
    byName[polyline.xdataStrings[0]] = &polyline;
  }
  EXPECT_EQ(dxf.polylines.size(), kExportedNames.size());
  std::set<std::string> names;
  for (const auto& [name, polyline] : byName) names.insert(name);
  EXPECT_EQ(names, kExportedNames);

  const DxfPolyline& main = *byName.at("pipe-1");
  EXPECT_EQ(main.layer, "PIPE");
  EXPECT_EQ(main.xdataReals[0], kMainRadius);
  EXPECT_EQ(main.xdataIntegers[0], 0);
  ASSERT_EQ(main.vertices.size(), 2u);
  EXPECT_EQ(main.vertices[0], Vector3d(0, 0, 1));
  EXPECT_EQ(main.vertices[1], Vector3d(2, 0, 1));

  // The elbow's centre line is its arc, every sample exactly as in the network.
  const DxfPolyline& elbow = *byName.at("elbow-1");
  EXPECT_EQ(elbow.layer, "ELBOW");
  EXPECT_EQ(elbow.xdataReals[1], kBendRadius);
  EXPECT_EQ(elbow.vertices, network.findJoint(1)->axis);
  for (const auto& p : elbow.vertices) EXPECT_NEAR((p - Vector3d(2, kBendRadius, 1)).norm(), kBendRadius, 1e-12);

  EXPECT_EQ(byName.at("tee-2")->layer, "TEE");
  EXPECT_EQ(byName.at("tee-2")->xdataReals[0], kBranchRadius);
  EXPECT_EQ(byName.at("boundary-4")->layer, "BOUNDARY");
  EXPECT_EQ(byName.at("boundary-4")->xdataStrings[1], "proposed");
  EXPECT_EQ(byName.at("pipe-5")->xdataIntegers[0], -1);
}

// ---------------------------------------------------------------------------------------------
// PCF

struct PcfPoint {
  Vector3d position = Vector3d::Zero();  // millimetres
  double bore = 0.0;                     // millimetres; 0 when not given
};

struct PcfComponent {
  std::string type;
  std::vector<PcfPoint> endPoints;
  std::vector<PcfPoint> centrePoints;
  std::vector<PcfPoint> branchPoints;
  std::string skey;
};

struct PcfFile {
  std::map<std::string, std::string> units;
  std::vector<std::pair<std::string, std::vector<PcfComponent>>> pipelines;
};

PcfFile parsePcf(const std::string& text) {
  PcfFile pcf;
  for (const auto& line : splitLines(text)) {
    const auto words = splitWords(line);
    if (words.empty()) continue;
    const bool attribute = line[0] == ' ';
    if (!attribute && words[0].rfind("UNITS-", 0) == 0) {
      pcf.units[words[0]] = words.at(1);
    } else if (!attribute && words[0] == "PIPELINE-REFERENCE") {
      pcf.pipelines.push_back({words.at(1), {}});
    } else if (!attribute && words[0] != "ISOGEN-FILES") {
      pcf.pipelines.back().second.push_back({words[0], {}, {}, {}, {}});
    } else if (attribute) {
      auto& component = pcf.pipelines.back().second.back();
      if (words[0] == "SKEY") {
        component.skey = words.at(1);
        continue;
      }
      PcfPoint point;
      point.position = {std::stod(words.at(1)), std::stod(words.at(2)), std::stod(words.at(3))};
      if (words.size() > 4) point.bore = std::stod(words[4]);
      if (words[0] == "END-POINT") component.endPoints.push_back(point);
      if (words[0] == "CENTRE-POINT") component.centrePoints.push_back(point);
      if (words[0] == "BRANCH1-POINT") component.branchPoints.push_back(point);
    }
  }
  return pcf;
}

// Connection points (END-POINTs and BRANCH1-POINTs) of a pipeline that no other component shares.
std::vector<Vector3d> openEnds(const std::vector<PcfComponent>& components) {
  std::vector<std::pair<Vector3d, std::size_t>> points;
  for (std::size_t c = 0; c < components.size(); ++c) {
    for (const auto& p : components[c].endPoints) points.emplace_back(p.position, c);
    for (const auto& p : components[c].branchPoints) points.emplace_back(p.position, c);
  }
  std::vector<Vector3d> open;
  for (const auto& [p, owner] : points) {
    const bool shared = std::any_of(points.begin(), points.end(), [&, owner = owner](const auto& other) {
      return other.second != owner && (other.first - p).norm() < 0.15;
    });
    if (!shared) open.push_back(p);
  }
  return open;
}

bool containsPoint(const std::vector<Vector3d>& points, const Vector3d& p, double tolerance) {
  return std::any_of(points.begin(), points.end(), [&](const Vector3d& q) { return (q - p).norm() < tolerance; });
}

// Pairs of connection points of different components at one place whose bores differ.
int boreMismatches(const std::vector<PcfComponent>& components) {
  int mismatches = 0;
  for (std::size_t c = 0; c < components.size(); ++c) {
    for (std::size_t d = c + 1; d < components.size(); ++d) {
      for (const auto& p : components[c].endPoints) {
        for (const auto& q : components[d].endPoints) {
          mismatches += (p.position - q.position).norm() < 0.06 && p.bore != q.bore;
        }
        for (const auto& q : components[d].branchPoints) {
          mismatches += (p.position - q.position).norm() < 0.06 && p.bore != q.bore;
        }
      }
    }
  }
  return mismatches;
}

TEST(Export, PcfRunsWithElbowAndTee) {
  TempDir dir;
  ExportOptions options;
  options.pcfBore = PcfBore::OutsideDiameter;
  exportNetwork(sampleNetwork(), ExportFormat::Pcf, dir / "net.pcf", options);
  const PcfFile pcf = parsePcf(test::readFile(dir / "net.pcf"));
  EXPECT_EQ(pcf.units.at("UNITS-BORE"), "MM");
  EXPECT_EQ(pcf.units.at("UNITS-CO-ORDS"), "MM");
  // The run, then the elements in no run grouped by connection: pipe 5 alone (its joint is
  // rejected), pipes 6 and 7 with their boundary joint.
  ASSERT_EQ(pcf.pipelines.size(), 3u);
  EXPECT_EQ(pcf.pipelines[0].first, "RUN-0");
  EXPECT_EQ(pcf.pipelines[1].first, "GROUP-1");
  EXPECT_EQ(pcf.pipelines[2].first, "GROUP-2");
  EXPECT_EQ(pcf.pipelines[1].second.size(), 1u);
  EXPECT_EQ(pcf.pipelines[2].second.size(), 3u);
  for (const auto& component : pcf.pipelines[2].second) EXPECT_EQ(component.type, "PIPE");

  const auto& run = pcf.pipelines[0].second;
  std::map<std::string, std::vector<const PcfComponent*>> byType;
  for (const auto& component : run) byType[component.type].push_back(&component);
  // Pipe 1 is cut around the tee: two pieces, plus pipes 2 and 3.
  ASSERT_EQ(byType["PIPE"].size(), 4u);
  ASSERT_EQ(byType["ELBOW"].size(), 1u);
  ASSERT_EQ(byType["TEE"].size(), 1u);

  const PcfComponent& elbow = *byType["ELBOW"][0];
  ASSERT_EQ(elbow.endPoints.size(), 2u);
  ASSERT_EQ(elbow.centrePoints.size(), 1u);
  EXPECT_EQ(elbow.skey, "ELBW");
  EXPECT_LT((elbow.endPoints[0].position - Vector3d(2000, 0, 1000)).norm(), 0.06);
  EXPECT_LT((elbow.endPoints[1].position - Vector3d(2150, 150, 1000)).norm(), 0.06);
  EXPECT_DOUBLE_EQ(elbow.endPoints[0].bore, 100.0);
  // Where the tangent lines at the two ends meet: the corner of the bend.
  EXPECT_LT((elbow.centrePoints[0].position - Vector3d(2150, 0, 1000)).norm(), 0.06);

  const PcfComponent& tee = *byType["TEE"][0];
  ASSERT_EQ(tee.endPoints.size(), 2u);
  ASSERT_EQ(tee.centrePoints.size(), 1u);
  ASSERT_EQ(tee.branchPoints.size(), 1u);
  EXPECT_EQ(tee.skey, "TEBW");
  EXPECT_LT((tee.centrePoints[0].position - Vector3d(1000, 0, 1000)).norm(), 0.06);
  EXPECT_LT((tee.branchPoints[0].position - Vector3d(1000, 0, 950)).norm(), 0.06);
  EXPECT_DOUBLE_EQ(tee.branchPoints[0].bore, 60.0);
  EXPECT_DOUBLE_EQ(tee.endPoints[0].bore, 100.0);
  const std::vector<Vector3d> teeEnds = {tee.endPoints[0].position, tee.endPoints[1].position};
  EXPECT_TRUE(containsPoint(teeEnds, {950, 0, 1000}, 0.06));
  EXPECT_TRUE(containsPoint(teeEnds, {1050, 0, 1000}, 0.06));

  // Every component connects to the next; the only open ends are the run's three extremities.
  const auto open = openEnds(run);
  EXPECT_EQ(open.size(), 3u);
  EXPECT_TRUE(containsPoint(open, {0, 0, 1000}, 0.06));
  EXPECT_TRUE(containsPoint(open, {2150, 1500, 1000}, 0.06));
  EXPECT_TRUE(containsPoint(open, {1000, 0, 200}, 0.06));
}

TEST(Export, PcfIsWrittenWithTheNetworksUpAxisAsZ) {
  // The sample network turned so that each axis is up, told so: its PCF is the z-up network's,
  // byte for byte (isometrics draw elevations along z). The other formats keep its co-ordinates.
  TempDir dir;
  exportNetwork(sampleNetwork(), ExportFormat::Pcf, dir / "z.pcf");
  exportNetwork(sampleNetwork(), ExportFormat::Obj, dir / "z.obj");
  const std::string upright = test::readFile(dir / "z.pcf");
  for (const std::string& name : upAxisNames()) {
    const UpAxis up = upAxisFromString(name);
    const auto [turned, options] = turnedSample(up);
    exportNetwork(turned, ExportFormat::Pcf, dir / "turned.pcf", options);
    EXPECT_EQ(test::readFile(dir / "turned.pcf"), upright) << name;
    exportNetwork(turned, ExportFormat::Obj, dir / "turned.obj", options);
    EXPECT_EQ(test::readFile(dir / "turned.obj") == test::readFile(dir / "z.obj"), up == UpAxis::PlusZ) << name;
    // Not told, the turned network's PCF lies on its side.
    if (up != UpAxis::PlusZ) {
      exportNetwork(turned, ExportFormat::Pcf, dir / "untold.pcf");
      EXPECT_NE(test::readFile(dir / "untold.pcf"), upright) << name;
    }
  }
}

TEST(Export, PcfNominalBoresAgreeAtEveryConnectionWithReducersWhereTheSizeChanges) {
  // A 6" pipe (fitted 3 mm wide, as scans fit them) turns through an elbow into an 8" one, which
  // continues across a gap into a 6" pipe carrying a 2" branch.
  PipeNetwork network;
  network.pipes = {makePipe(1, 0.0855, {0, 0, 0}, {2, 0, 0}, 0), makePipe(2, 0.1095, {2.3, 0.3, 0}, {2.3, 2, 0}, 0),
                   makePipe(3, 0.0842, {2.3, 2.1, 0}, {2.3, 4, 0}, 0),
                   makePipe(4, 0.031, {2.3 + 0.0842, 3, 0}, {3, 3, 0}, 0)};
  network.joints = {makeJoint(1, JointType::Elbow, {1, 2}, 0.0975, sampleArc({2, 0.3, 0}, {2, 0, 0}, {2.3, 0.3, 0}, 0.01)),
                    makeJoint(2, JointType::Boundary, {2, 3}, 0.097, {{2.3, 2, 0}, {2.3, 2.1, 0}}),
                    makeJoint(3, JointType::Tee, {3, 4}, 0.031, {{2.3, 3, 0}, {2.3 + 0.0842, 3, 0}})};
  network.joints[0].bendRadius = 0.3;
  network.runs.push_back({0, {1, 2, 3, 4}, {1, 2, 3}});
  network.validate();

  TempDir dir;
  exportNetwork(network, ExportFormat::Pcf, dir / "net.pcf");  // nominal bores by default
  const PcfFile pcf = parsePcf(test::readFile(dir / "net.pcf"));
  ASSERT_EQ(pcf.pipelines.size(), 1u);
  const auto& run = pcf.pipelines[0].second;
  std::map<std::string, std::vector<const PcfComponent*>> byType;
  for (const auto& component : run) byType[component.type].push_back(&component);
  ASSERT_EQ(byType["PIPE"].size(), 5u);  // pipe 3 cut around the tee
  std::set<double> pipeBores;
  for (const PcfComponent* pipe : byType["PIPE"]) {
    EXPECT_EQ(pipe->endPoints.at(0).bore, pipe->endPoints.at(1).bore);
    pipeBores.insert(pipe->endPoints[0].bore);
  }
  EXPECT_EQ(pipeBores, (std::set<double>{50, 150, 200}));

  // The elbow reduces from its 6" pipe to its 8" one; the gap between the 8" and the 6" pipe is a reducer.
  ASSERT_EQ(byType["ELBOW"].size(), 1u);
  const PcfComponent& bend = *byType["ELBOW"][0];
  EXPECT_LT((bend.endPoints.at(0).position - Vector3d(2000, 0, 0)).norm(), 0.06);
  EXPECT_EQ(bend.endPoints[0].bore, 150);
  EXPECT_EQ(bend.endPoints.at(1).bore, 200);
  ASSERT_EQ(byType["REDUCER-CONCENTRIC"].size(), 1u);
  const PcfComponent& reducer = *byType["REDUCER-CONCENTRIC"][0];
  EXPECT_EQ(reducer.skey, "RCBW");
  EXPECT_LT((reducer.endPoints.at(0).position - Vector3d(2300, 2000, 0)).norm(), 0.06);
  EXPECT_EQ(reducer.endPoints[0].bore, 200);
  EXPECT_LT((reducer.endPoints.at(1).position - Vector3d(2300, 2100, 0)).norm(), 0.06);
  EXPECT_EQ(reducer.endPoints[1].bore, 150);
  ASSERT_EQ(byType["TEE"].size(), 1u);
  EXPECT_EQ(byType["TEE"][0]->endPoints.at(0).bore, 150);
  EXPECT_EQ(byType["TEE"][0]->branchPoints.at(0).bore, 50);
  EXPECT_EQ(boreMismatches(run), 0);
  EXPECT_EQ(openEnds(run).size(), 3u);

  // The fitted outside diameters instead: each element's own, no reducer.
  ExportOptions options;
  options.pcfBore = PcfBore::OutsideDiameter;
  exportNetwork(network, ExportFormat::Pcf, dir / "outside.pcf", options);
  const PcfFile outsidePcf = parsePcf(test::readFile(dir / "outside.pcf"));
  const auto& outside = outsidePcf.pipelines.at(0).second;
  EXPECT_TRUE(std::none_of(outside.begin(), outside.end(),
                           [](const PcfComponent& c) { return c.type == "REDUCER-CONCENTRIC"; }));
  EXPECT_EQ(outside.front().endPoints.at(0).bore, 171.0);
  EXPECT_GT(boreMismatches(outside), 0);
}

TEST(Export, PcfBoreNames) {
  EXPECT_EQ(pcfBoreFromString("Nominal"), PcfBore::Nominal);
  EXPECT_EQ(pcfBoreFromString("outside"), PcfBore::OutsideDiameter);
  EXPECT_EQ(pcfBoreFromString("od"), std::nullopt);
  EXPECT_EQ(toString(PcfBore::OutsideDiameter), "outside");
}

// A bend of radius 0.2 m around the origin, from (0.2, 0, 0) through `angle` about z, through PCF.
std::vector<PcfComponent> bendThroughPcf(double angle) {
  PipeNetwork network;
  const Vector3d start(0.2, 0, 0);
  Joint bend;
  bend.id = 1;
  bend.radius = 0.05;
  bend.bendRadius = 0.2;
  bend.axis = sampleArc(Vector3d::Zero(), start, Eigen::AngleAxisd(angle, Vector3d::UnitZ()) * start, 0.01);
  network.joints.push_back(bend);
  TempDir dir;
  exportNetwork(network, ExportFormat::Pcf, dir / "bend.pcf");
  const PcfFile pcf = parsePcf(test::readFile(dir / "bend.pcf"));
  EXPECT_EQ(pcf.pipelines.size(), 1u);
  return pcf.pipelines.empty() ? std::vector<PcfComponent>{} : pcf.pipelines[0].second;
}

// Component j of that bend written in equal ELBOWs of `step`: its ends on the arc, its
// CENTRE-POINT where the tangents at them meet.
void expectElbowPiece(const PcfComponent& elbow, int j, double step) {
  const Vector3d start(200.0, 0, 0);  // mm
  EXPECT_EQ(elbow.type, "ELBOW");
  EXPECT_LT((elbow.endPoints.at(0).position - Eigen::AngleAxisd(j * step, Vector3d::UnitZ()) * start).norm(), 0.06);
  EXPECT_LT((elbow.endPoints.at(1).position - Eigen::AngleAxisd((j + 1) * step, Vector3d::UnitZ()) * start).norm(), 0.06);
  const Vector3d corner = 200.0 / std::cos(0.5 * step) * (Eigen::AngleAxisd((j + 0.5) * step, Vector3d::UnitZ()) * Vector3d::UnitX());
  EXPECT_LT((elbow.centrePoints.at(0).position - corner).norm(), 0.06);
}

TEST(Export, PcfSplitsBendsWellBeyondNinetyDegrees) {
  // 135° becomes two elbows of 67.5°.
  const std::vector<PcfComponent> components = bendThroughPcf(0.75 * kPi);
  ASSERT_EQ(components.size(), 2u);
  for (int j = 0; j < 2; ++j) expectElbowPiece(components[static_cast<std::size_t>(j)], j, 0.375 * kPi);
}

TEST(Export, PcfKeepsABendFittedAFewDegreesPastNinetyOneElbow) {
  // A 90° fitting fitted at 93° (the pump room's riser elbow comes out at 90.7°) is one ELBOW; at
  // 96° it is two of 48°.
  const std::vector<PcfComponent> fitted = bendThroughPcf(93.0 * kDegree);
  ASSERT_EQ(fitted.size(), 1u);
  expectElbowPiece(fitted[0], 0, 93.0 * kDegree);
  const std::vector<PcfComponent> wider = bendThroughPcf(96.0 * kDegree);
  ASSERT_EQ(wider.size(), 2u);
  for (int j = 0; j < 2; ++j) expectElbowPiece(wider[static_cast<std::size_t>(j)], j, 48.0 * kDegree);
}

// ---------------------------------------------------------------------------------------------
// A generated truth network through every format.

// ---------------------------------------------------------------------------------------------
// IFC: a small reader of ISO 10303-21 text (the DATA section's instances and their arguments)

// An argument: a list, a reference (#12), a string, a typed value (IFCREAL(0.5)), or a bare token
// (a number, an enumeration such as .BEND., $ or *).
struct StepValue {
  enum class Kind { List, Reference, String, Typed, Token } kind = Kind::Token;
  std::string text;               // the reference's number, the string, the type's or token's text
  std::vector<StepValue> items;   // a list's items, a typed value's one argument

  int reference() const { return kind == Kind::Reference ? std::stoi(text) : -1; }
  double real() const { return std::stod(kind == Kind::Typed ? items.at(0).text : text); }
};

struct StepInstance {
  std::string type;
  std::vector<StepValue> arguments;
};

struct IfcFile {
  std::vector<std::string> header;  // the lines before DATA;
  std::map<int, StepInstance> instances;
  bool endsProperly = false;

  std::vector<int> ofType(const std::string& type) const {
    std::vector<int> found;
    for (const auto& [id, instance] : instances) {
      if (instance.type == type) found.push_back(id);
    }
    return found;
  }
  const StepInstance& at(const StepValue& reference) const { return instances.at(reference.reference()); }
  // Every reference in every argument names an instance of the file.
  bool referencesResolve() const {
    std::vector<const StepValue*> open;
    for (const auto& [id, instance] : instances) {
      for (const auto& argument : instance.arguments) open.push_back(&argument);
    }
    while (!open.empty()) {
      const StepValue* value = open.back();
      open.pop_back();
      if (value->kind == StepValue::Kind::Reference && !instances.count(value->reference())) return false;
      for (const auto& item : value->items) open.push_back(&item);
    }
    return true;
  }
};

class StepParser {
 public:
  explicit StepParser(const std::string& text) : text_(text) {}

  std::vector<StepValue> arguments() {
    expect('(');
    std::vector<StepValue> values;
    if (peek() == ')') {
      ++at_;
      return values;
    }
    for (;;) {
      values.push_back(value());
      const char next = text_.at(at_++);
      if (next == ')') return values;
      if (next != ',') throw std::runtime_error("expected , or ) at " + std::to_string(at_));
    }
  }

 private:
  StepValue value() {
    StepValue v;
    const char c = peek();
    if (c == '(') {
      v.kind = StepValue::Kind::List;
      v.items = arguments();
    } else if (c == '#') {
      ++at_;
      v.kind = StepValue::Kind::Reference;
      while (std::isdigit(static_cast<unsigned char>(peek()))) v.text += text_[at_++];
    } else if (c == '\'') {
      ++at_;
      v.kind = StepValue::Kind::String;
      for (;;) {
        const char d = text_.at(at_++);
        if (d == '\'' && peek() == '\'') {
          v.text += '\'';
          ++at_;
        } else if (d == '\'') {
          break;
        } else {
          v.text += d;
        }
      }
    } else {
      while (peek() != ',' && peek() != ')' && peek() != '(') v.text += text_[at_++];
      if (peek() == '(') {
        v.kind = StepValue::Kind::Typed;
        v.items = arguments();
      }
    }
    return v;
  }
  char peek() const { return text_.at(at_); }
  void expect(char c) {
    if (text_.at(at_++) != c) throw std::runtime_error(std::string("expected ") + c + " at " + std::to_string(at_));
  }

  const std::string& text_;
  std::size_t at_ = 0;
};

IfcFile parseIfc(const std::string& text) {
  IfcFile file;
  bool data = false;
  for (const std::string& line : splitLines(text)) {
    if (line == "DATA;") {
      data = true;
    } else if (!data) {
      file.header.push_back(line);
    } else if (line == "END-ISO-10303-21;") {
      file.endsProperly = true;
    } else if (!line.empty() && line[0] == '#') {
      const std::size_t equals = line.find('='), open = line.find('(');
      StepInstance instance;
      instance.type = line.substr(equals + 1, open - equals - 1);
      const std::string arguments = line.substr(open, line.size() - open - 1);  // without the ';'
      instance.arguments = StepParser(arguments).arguments();
      EXPECT_TRUE(file.instances.emplace(std::stoi(line.substr(1, equals - 1)), instance).second) << line;
    }
  }
  return file;
}

// One product of an IFC export as read back: its entity, name, predefined type, centre line and
// radius, and its PipeRun_Element properties.
struct IfcProduct {
  std::string type, globalId, name, predefined;
  std::vector<Vector3d> axis;
  double radius = 0.0;
  std::map<std::string, StepValue> properties;
};

std::map<std::string, IfcProduct> ifcProducts(const IfcFile& file) {
  std::map<int, IfcProduct> byId;
  for (const std::string type : {"IFCPIPESEGMENT", "IFCPIPEFITTING"}) {
    for (const int id : file.ofType(type)) {
      const StepInstance& product = file.instances.at(id);
      IfcProduct read;
      read.type = type;
      read.globalId = product.arguments.at(0).text;
      read.name = product.arguments.at(2).text;
      read.predefined = product.arguments.at(8).text;
      const StepInstance& definition = file.at(product.arguments.at(6));
      const StepInstance& shape = file.at(definition.arguments.at(2).items.at(0));
      EXPECT_EQ(shape.arguments.at(2).text, "AdvancedSweptSolid");
      const StepInstance& solid = file.at(shape.arguments.at(3).items.at(0));
      EXPECT_EQ(solid.type, "IFCSWEPTDISKSOLID");
      read.radius = solid.arguments.at(1).real();
      const StepInstance& line = file.at(solid.arguments.at(0));
      EXPECT_EQ(line.type, "IFCPOLYLINE");
      for (const StepValue& vertex : line.arguments.at(0).items) {
        const auto& xyz = file.at(vertex).arguments.at(0).items;
        read.axis.emplace_back(xyz.at(0).real(), xyz.at(1).real(), xyz.at(2).real());
      }
      byId.emplace(id, read);
    }
  }
  for (const int relation : file.ofType("IFCRELDEFINESBYPROPERTIES")) {
    const StepInstance& defines = file.instances.at(relation);
    const StepInstance& set = file.at(defines.arguments.at(5));
    EXPECT_EQ(set.arguments.at(2).text, "PipeRun_Element");
    for (const StepValue& object : defines.arguments.at(4).items) {
      for (const StepValue& property : set.arguments.at(4).items) {
        const StepInstance& single = file.at(property);
        byId.at(object.reference()).properties[single.arguments.at(0).text] = single.arguments.at(2);
      }
    }
  }
  std::map<std::string, IfcProduct> byName;
  for (auto& [id, product] : byId) byName.emplace(product.name, std::move(product));
  return byName;
}

TEST(Export, IfcProductsAreSweptAlongTheCentreLinesAndRunsAreSystems) {
  const PipeNetwork network = sampleNetwork();
  TempDir dir;
  exportNetwork(network, ExportFormat::Ifc, dir / "net.ifc");
  const IfcFile file = parseIfc(test::readFile(dir / "net.ifc"));
  ASSERT_FALSE(file.header.empty());
  EXPECT_EQ(file.header.front(), "ISO-10303-21;");
  EXPECT_NE(std::find(file.header.begin(), file.header.end(), "FILE_SCHEMA(('IFC4'));"), file.header.end());
  EXPECT_TRUE(file.endsProperly);
  EXPECT_TRUE(file.referencesResolve());
  // Metres.
  const auto units = file.ofType("IFCSIUNIT");
  EXPECT_TRUE(std::any_of(units.begin(), units.end(), [&](int id) {
    return file.instances.at(id).arguments.at(1).text == ".LENGTHUNIT." && file.instances.at(id).arguments.at(3).text == ".METRE.";
  }));

  // Every element kept, as its product, along its centre line.
  const auto products = ifcProducts(file);
  std::set<std::string> names, globalIds;
  for (const auto& [name, product] : products) {
    names.insert(name);
    globalIds.insert(product.globalId);
    ASSERT_EQ(product.globalId.size(), 22u) << name;
    EXPECT_EQ(product.globalId.find_first_not_of(
                  "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz_$"),
              std::string::npos)
        << name;
    EXPECT_LE(product.globalId[0], '3') << name;  // the first character holds two bits
  }
  EXPECT_EQ(names, kExportedNames);
  EXPECT_EQ(globalIds.size(), products.size());
  for (const Pipe& pipe : network.pipes) {
    if (pipe.status == PipeStatus::Deleted) continue;
    const IfcProduct& product = products.at("pipe-" + std::to_string(pipe.id));
    EXPECT_EQ(product.type, "IFCPIPESEGMENT");
    EXPECT_EQ(product.predefined, ".RIGIDSEGMENT.");
    EXPECT_EQ(product.radius, pipe.radius);
    ASSERT_EQ(product.axis.size(), 2u);
    EXPECT_EQ(product.axis[0], pipe.start);
    EXPECT_EQ(product.axis[1], pipe.end);
    EXPECT_EQ(product.properties.at("ReviewStatus").items.at(0).text, toString(pipe.status));
    EXPECT_EQ(product.properties.at("Confidence").real(), pipe.confidence);
    EXPECT_EQ(product.properties.at("OutsideDiameter").real(), 2.0 * pipe.radius);
  }
  const IfcProduct& elbow = products.at("elbow-1");
  EXPECT_EQ(elbow.type, "IFCPIPEFITTING");
  EXPECT_EQ(elbow.predefined, ".BEND.");
  EXPECT_EQ(elbow.axis, network.joints[0].axis);
  EXPECT_EQ(elbow.properties.at("BendRadius").real(), kBendRadius);
  EXPECT_NEAR(elbow.properties.at("BendAngle").real(), 0.5 * kPi, 1e-9);  // radians, the model's unit
  EXPECT_EQ(elbow.properties.at("NominalSize").items.at(0).text, "3-1/2\" DN 90");
  const IfcProduct& tee = products.at("tee-2");
  EXPECT_EQ(tee.predefined, ".JUNCTION.");
  EXPECT_EQ(tee.radius, kBranchRadius);
  EXPECT_EQ(products.at("boundary-4").type, "IFCPIPESEGMENT");
  EXPECT_EQ(products.at("boundary-4").properties.at("ReviewStatus").items.at(0).text, "proposed");

  // All in the site, and the run a system of its five elements (pipes in no run are in none).
  const auto contained = file.ofType("IFCRELCONTAINEDINSPATIALSTRUCTURE");
  ASSERT_EQ(contained.size(), 1u);
  EXPECT_EQ(file.at(file.instances.at(contained[0]).arguments.at(5)).type, "IFCSITE");
  EXPECT_EQ(file.instances.at(contained[0]).arguments.at(4).items.size(), kExportedNames.size());
  const auto systems = file.ofType("IFCDISTRIBUTIONSYSTEM");
  ASSERT_EQ(systems.size(), 1u);
  EXPECT_EQ(file.instances.at(systems[0]).arguments.at(2).text, "run 0");
  const auto groups = file.ofType("IFCRELASSIGNSTOGROUP");
  ASSERT_EQ(groups.size(), 1u);
  std::set<std::string> members;
  for (const StepValue& member : file.instances.at(groups[0]).arguments.at(4).items) {
    members.insert(file.at(member).arguments.at(2).text);
  }
  EXPECT_EQ(members, (std::set<std::string>{"pipe-1", "pipe-2", "pipe-3", "elbow-1", "tee-2"}));
  EXPECT_EQ(file.instances.at(groups[0]).arguments.at(6).reference(), systems[0]);
  EXPECT_FALSE(products.at("pipe-6").properties.count("Run"));
  EXPECT_EQ(products.at("pipe-1").properties.at("Run").items.at(0).text, "0");

  // Each product typed once, by its kind and nominal size; the types declared in the project; a
  // segment type with its diameters in Pset_PipeSegmentTypeCommon.
  std::map<std::string, std::string> typeOf;  // product name -> type name
  for (const int relation : file.ofType("IFCRELDEFINESBYTYPE")) {
    const StepInstance& defines = file.instances.at(relation);
    const StepInstance& type = file.at(defines.arguments.at(5));
    for (const StepValue& object : defines.arguments.at(4).items) {
      EXPECT_TRUE(typeOf.emplace(file.at(object).arguments.at(2).text, type.arguments.at(2).text).second);
    }
  }
  EXPECT_EQ(typeOf.size(), kExportedNames.size());
  EXPECT_EQ(typeOf.at("pipe-1"), "pipe 3-1/2\" DN 90");  // 100 mm outside: 3-1/2" (101.6)
  EXPECT_EQ(typeOf.at("pipe-2"), "pipe 3-1/2\" DN 90");
  EXPECT_EQ(typeOf.at("boundary-4"), typeOf.at("pipe-6"));  // a gap piece is a pipe of its size
  EXPECT_EQ(typeOf.at("elbow-1"), "elbow 3-1/2\" DN 90");
  EXPECT_EQ(typeOf.at("tee-2"), "tee 2\" DN 50");
  const auto declares = file.ofType("IFCRELDECLARES");
  ASSERT_EQ(declares.size(), 1u);
  EXPECT_EQ(file.at(file.instances.at(declares[0]).arguments.at(4)).type, "IFCPROJECT");
  EXPECT_EQ(file.instances.at(declares[0]).arguments.at(5).items.size(),
            file.ofType("IFCPIPESEGMENTTYPE").size() + file.ofType("IFCPIPEFITTINGTYPE").size());
  for (const int id : file.ofType("IFCPIPESEGMENTTYPE")) {
    const StepInstance& type = file.instances.at(id);
    if (type.arguments.at(2).text != "pipe 3-1/2\" DN 90") continue;
    const StepInstance& set = file.at(type.arguments.at(5).items.at(0));
    EXPECT_EQ(set.arguments.at(2).text, "Pset_PipeSegmentTypeCommon");
    std::map<std::string, double> diameters;
    for (const StepValue& property : set.arguments.at(4).items) {
      diameters[file.at(property).arguments.at(0).text] = file.at(property).arguments.at(2).real();
    }
    EXPECT_DOUBLE_EQ(diameters.at("NominalDiameter"), 0.09);
    EXPECT_DOUBLE_EQ(diameters.at("OuterDiameter"), 0.1016);
  }
}

TEST(Export, IfcIdsAreStableForANetworkAndItsModelStandsOnZ) {
  // The same network exported twice gives the same GlobalIds (a model updated in a BIM tool keeps
  // its elements); a network moved gives others. Turned to another axis up and told so, it gives
  // the z-up network's model (an IFC model's z is up), but for the time of export.
  const auto withoutTime = [](const std::filesystem::path& path) {
    std::string kept;
    for (const std::string& line : splitLines(test::readFile(path))) {
      if (line.rfind("FILE_NAME(", 0) != 0) kept += line + "\n";
    }
    return kept;
  };
  TempDir dir;
  exportNetwork(sampleNetwork(), ExportFormat::Ifc, dir / "a.ifc");
  exportNetwork(sampleNetwork(), ExportFormat::Ifc, dir / "b.ifc");
  EXPECT_EQ(withoutTime(dir / "a.ifc"), withoutTime(dir / "b.ifc"));
  exportNetwork(shifted(sampleNetwork(), Vector3d(0.001, 0, 0)), ExportFormat::Ifc, dir / "moved.ifc");
  const auto idsOf = [](const std::filesystem::path& path) {
    const IfcFile file = parseIfc(test::readFile(path));
    std::set<std::string> ids;
    for (const auto& [name, product] : ifcProducts(file)) ids.insert(product.globalId);
    for (const std::string type : {"IFCPROJECT", "IFCSITE", "IFCDISTRIBUTIONSYSTEM"}) {
      for (const int id : file.ofType(type)) ids.insert(file.instances.at(id).arguments.at(0).text);
    }
    return ids;
  };
  const auto original = idsOf(dir / "a.ifc"), movedIds = idsOf(dir / "moved.ifc");
  std::vector<std::string> shared;
  std::set_intersection(original.begin(), original.end(), movedIds.begin(), movedIds.end(), std::back_inserter(shared));
  EXPECT_TRUE(shared.empty());

  // The header names the file: STEP strings are ASCII, with other characters written as their codes.
  exportNetwork(sampleNetwork(), ExportFormat::Ifc, dir / "r\u00e9seau 'n\u00b0 2'.ifc");
  EXPECT_EQ(splitLines(test::readFile(dir / "r\u00e9seau 'n\u00b0 2'.ifc")).at(3).rfind(
                "FILE_NAME('r\\X2\\00E9\\X0\\seau ''n\\X2\\00B0\\X0\\ 2''.ifc','", 0),
            0u);

  for (const std::string& name : upAxisNames()) {
    const auto [turned, options] = turnedSample(upAxisFromString(name));
    exportNetwork(turned, ExportFormat::Ifc, dir / "turned.ifc", options);
    EXPECT_EQ(withoutTime(dir / "turned.ifc"), withoutTime(dir / "a.ifc")) << name;
  }
}

double distanceToLine(const Vector3d& p, const Vector3d& a, const Vector3d& b) {
  return (p - a).cross((b - a).normalized()).norm();
}

TEST(Export, TruthNetworkEveryFormat) {
  SceneParams params;
  params.seed = 1;
  const PipeNetwork truth = synth::buildSceneLayout(params).truth;
  int elbows = 0, tees = 0;
  for (const auto& joint : truth.joints) {
    elbows += joint.type == JointType::Elbow;
    tees += joint.type == JointType::Tee;
  }
  ASSERT_GT(elbows, 0);
  ASSERT_GT(tees, 0);
  const std::size_t elements = truth.pipes.size() + truth.joints.size();
  TempDir dir;

  exportNetwork(truth, ExportFormat::Obj, dir / "truth.obj");
  vtkNew<vtkOBJReader> obj;
  obj->SetFileName((dir / "truth.obj").c_str());
  obj->Update();
  const auto parts = partsByCellArray(obj->GetOutput(), "GroupIds");
  EXPECT_EQ(parts.size(), elements);
  for (const auto& [group, part] : parts) {
    EXPECT_TRUE(part.closedAndOriented()) << group;
    EXPECT_GT(part.volume, 0.0) << group;
  }

  exportNetwork(truth, ExportFormat::Csv, dir / "truth.csv");
  EXPECT_EQ(splitLines(test::readFile(dir / "truth.csv")).size(), 1 + elements);
  exportNetwork(truth, ExportFormat::Dxf, dir / "truth.dxf");
  EXPECT_EQ(parseDxf(test::readFile(dir / "truth.dxf")).polylines.size(), elements);

  // PCF: a pipeline per run, every elbow's CENTRE-POINT on the centre lines of both its pipes.
  exportNetwork(truth, ExportFormat::Pcf, dir / "truth.pcf");
  const PcfFile pcf = parsePcf(test::readFile(dir / "truth.pcf"));
  EXPECT_EQ(pcf.pipelines.size(), truth.runs.size());
  int pcfElbows = 0, pcfTees = 0;
  for (const auto& [reference, components] : pcf.pipelines) {
    for (const auto& component : components) {
      pcfTees += component.type == "TEE";
      if (component.type != "ELBOW") continue;
      ++pcfElbows;
      ASSERT_EQ(component.centrePoints.size(), 1u);
      const Vector3d corner = component.centrePoints[0].position / 1000.0;
      for (const auto& end : component.endPoints) {
        const Vector3d at = end.position / 1000.0;
        const auto pipe = std::find_if(truth.pipes.begin(), truth.pipes.end(), [&](const Pipe& p) {
          return (p.start - at).norm() < 1e-4 || (p.end - at).norm() < 1e-4;
        });
        ASSERT_NE(pipe, truth.pipes.end()) << reference << ": no pipe ends at " << at.transpose();
        EXPECT_LT(distanceToLine(corner, pipe->start, pipe->end), 2e-4) << reference << " pipe " << pipe->id;
      }
    }
  }
  EXPECT_EQ(pcfElbows, elbows);  // the generator bends by 90° at most: one ELBOW each
  EXPECT_EQ(pcfTees, tees);
  // The generator's radii are nominal sizes: every connection agrees in bore.
  for (const auto& [reference, components] : pcf.pipelines) EXPECT_EQ(boreMismatches(components), 0) << reference;
}

TEST(Export, EmptyNetworkGivesValidEmptyFiles) {
  // Everything left out: only a deleted pipe and a rejected joint.
  PipeNetwork network = sampleNetwork();
  network.pipes = {network.pipes[3]};
  network.joints = {network.joints[2]};
  network.joints[0].pipeIds = {4};
  network.runs.clear();
  TempDir dir;
  for (ExportFormat format :
       {ExportFormat::Obj, ExportFormat::Ply, ExportFormat::Csv, ExportFormat::Dxf, ExportFormat::Pcf, ExportFormat::Ifc}) {
    exportNetwork(network, format, dir / ("empty." + toString(format)));
  }
  vtkNew<vtkOBJReader> obj;
  obj->SetFileName((dir / "empty.obj").c_str());
  obj->Update();
  EXPECT_EQ(obj->GetOutput()->GetNumberOfPoints(), 0);
  vtkNew<vtkPLYReader> ply;
  ply->SetFileName((dir / "empty.ply").c_str());
  ply->Update();
  EXPECT_EQ(ply->GetOutput()->GetNumberOfPoints(), 0);
  EXPECT_EQ(splitLines(test::readFile(dir / "empty.csv")).size(), 1u);
  const DxfFile dxf = parseDxf(test::readFile(dir / "empty.dxf"));
  EXPECT_TRUE(dxf.polylines.empty());
  EXPECT_TRUE(dxf.endsWithEof);
  const PcfFile pcf = parsePcf(test::readFile(dir / "empty.pcf"));
  EXPECT_TRUE(pcf.pipelines.empty());
  EXPECT_EQ(pcf.units.at("UNITS-BORE"), "MM");
  const IfcFile ifc = parseIfc(test::readFile(dir / "empty.ifc"));
  EXPECT_TRUE(ifc.ofType("IFCPIPESEGMENT").empty());
  EXPECT_EQ(ifc.ofType("IFCSITE").size(), 1u);
  EXPECT_TRUE(ifc.referencesResolve());
}

TEST(Export, RefusesBadOptionsAndUnwritablePaths) {
  TempDir dir;
  ExportOptions options;
  options.chordTolerance = 0.0;
  EXPECT_THROW(exportNetwork(sampleNetwork(), ExportFormat::Obj, dir / "a.obj", options), std::invalid_argument);
  options = {};
  options.maxSegments = 4;
  EXPECT_THROW(exportNetwork(sampleNetwork(), ExportFormat::Ply, dir / "a.ply", options), std::invalid_argument);
  EXPECT_THROW(exportNetwork(sampleNetwork(), ExportFormat::Csv, dir / "missing" / "a.csv"), OutputError);
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

}  // namespace
}  // namespace piperun
