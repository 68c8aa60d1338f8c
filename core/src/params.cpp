// The parameter table: one row per parameter, used for the JSON document, `piperun params`,
// "key=value" assignments and detecting which stage a change affects.

#include "piperun/params.h"

#include "piperun/error.h"
#include "json_text.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <variant>

namespace piperun {

namespace {

using nlohmann::ordered_json;
using FieldRef = std::variant<double*, int*, bool*, std::uint64_t*, UpAxis*>;

constexpr double kUnbounded = std::numeric_limits<double>::infinity();
/// Smallest tile edge: each tile runs every per-tile stage, so their count grows with the cube of
/// its inverse (a small-preset scene, 9 x 9 x 4 m, takes 7 s at 0.5 m and does not finish at 1 cm).
constexpr double kMinTileSize = 0.5;
/// Shortest axial section of the extents stage: shorter ones only multiply the sections.
constexpr double kMinSectionLength = 0.005;

/// A bound or a value as people write it: 0.5, 3, 1e-05.
std::string numberText(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

/// The values a parameter accepts: an interval whose ends are each open or closed.
struct Range {
  double low = -kUnbounded, high = kUnbounded;
  bool lowOpen = false, highOpen = false;

  bool contains(double value) const {
    if (std::isnan(value)) return false;
    const bool aboveLow = lowOpen ? value > low : value >= low;
    const bool belowHigh = highOpen ? value < high : value <= high;
    return aboveLow && belowHigh;
  }
  /// "> 0", ">= 3", "[0, 1]", "(0, 30]", ... ; empty when any value goes.
  std::string text() const {
    if (low == -kUnbounded && high == kUnbounded) return "";
    if (high == kUnbounded) return (lowOpen ? "> " : ">= ") + numberText(low);
    return (lowOpen ? "(" : "[") + numberText(low) + ", " + numberText(high) + (highOpen ? ")" : "]");
  }
};
constexpr Range anyValue() { return {}; }
constexpr Range atLeast(double low) { return {low, kUnbounded, false, false}; }
constexpr Range above(double low) { return {low, kUnbounded, true, false}; }
constexpr Range closed(double low, double high) { return {low, high, false, false}; }
constexpr Range open(double low, double high) { return {low, high, true, true}; }
constexpr Range closedOpen(double low, double high) { return {low, high, false, true}; }
constexpr Range openClosed(double low, double high) { return {low, high, true, false}; }

struct Field {
  const char* section;  // "" for top-level keys
  const char* key;
  const char* unit;
  std::optional<Stage> stage;  // the first stage whose result it changes; none: it trades memory for time only
  Range range;
  const char* description;
  FieldRef (*ref)(PipelineParams&);
};

#define PIPERUN_FIELD(section, key, unit, stage, member, range, description) \
  Field { section, key, unit, stage, range, description, [](PipelineParams& p) -> FieldRef { return &p.member; } }

const std::vector<Field>& fields() {
  static const std::vector<Field> table = {
      PIPERUN_FIELD("", "seed", "", Stage::Directions, seed, anyValue(), "Seed of every random choice; the same seed gives the same network"),
      PIPERUN_FIELD("", "rounds", "", Stage::Directions, rounds, atLeast(1), "Rounds of directions, placement and extents per tile on points not yet explained"),
      PIPERUN_FIELD("", "up", "", Stage::Joints, up, anyValue(), "The scan's up direction, x, y, z, -x, -y or -z (--up): the ground no pipe reaches below lies across it, a gently sloping pipe turns off the level direction under it, and the studio stands its cameras on it"),

      PIPERUN_FIELD("preprocess", "voxel_size", "m", Stage::Preprocess, preprocess.voxelSize, atLeast(0), "Voxel-grid leaf, the largest with auto_voxel: one point per occupied voxel (0 keeps every point)"),
      PIPERUN_FIELD("preprocess", "auto_voxel", "", Stage::Preprocess, preprocess.autoVoxel, anyValue(), "Leaf from the scan: twice its median point spacing, within 5 mm and voxel_size"),
      PIPERUN_FIELD("preprocess", "outlier_neighbors", "", Stage::Preprocess, preprocess.outlierNeighbors, atLeast(0), "Statistical outlier removal: neighbours whose mean distance is tested"),
      PIPERUN_FIELD("preprocess", "outlier_std_ratio", "", Stage::Preprocess, preprocess.outlierStdRatio, atLeast(0), "Remove points whose mean neighbour distance exceeds mean + ratio x std (0 disables)"),
      PIPERUN_FIELD("preprocess", "outlier_robust", "", Stage::Preprocess, preprocess.outlierRobust, anyValue(), "Median and MAD instead of mean and std (holds at heavy contamination, drops sparse far surfaces)"),
      PIPERUN_FIELD("preprocess", "sparse_surface_spacings", "", Stage::Preprocess, preprocess.sparseSurfaceSpacings, atLeast(0), "A point the outlier statistics take stays when its mean neighbour distance is within this many times the median one and at most twice its neighbours' (a sparse far surface; 0: the statistics alone)"),
      PIPERUN_FIELD("preprocess", "normal_neighbors", "", Stage::Preprocess, preprocess.normalNeighbors, atLeast(3), "Neighbours of the PCA normal estimation"),
      PIPERUN_FIELD("preprocess", "kept_neighbors_mb", "MB", std::nullopt, preprocess.keptNeighborsMB, atLeast(0), "The normals' neighbours are kept from the outlier search up to this memory, else searched again (the same normals, less memory: a change re-runs no stage)"),
      PIPERUN_FIELD("preprocess", "remove_planes", "", Stage::Preprocess, preprocess.removePlanes, anyValue(), "Remove large planar regions (floors, walls, equipment faces)"),
      PIPERUN_FIELD("preprocess", "plane_cell_size", "m", Stage::Preprocess, preprocess.planeCellSize, above(0), "Edge of the cells in which planes are detected"),
      PIPERUN_FIELD("preprocess", "plane_max_thickness", "m", Stage::Preprocess, preprocess.planeMaxThickness, above(0), "A cell is planar when the RMS distance to its plane is below this"),
      PIPERUN_FIELD("preprocess", "plane_max_curvature", "1/m", Stage::Preprocess, preprocess.planeMaxCurvature, atLeast(0), "A planar cell bends less than this, so pipe walls are never planes"),
      PIPERUN_FIELD("preprocess", "plane_min_area", "m2", Stage::Preprocess, preprocess.planeMinArea, atLeast(0), "Connected coplanar cells covering at least this area are removed"),
      PIPERUN_FIELD("preprocess", "tile_size", "m", Stage::Preprocess, preprocess.tileSize, atLeast(kMinTileSize), "Edge of the cubic sub-volumes processed independently"),
      PIPERUN_FIELD("preprocess", "tile_overlap", "m", Stage::Preprocess, preprocess.tileOverlap, atLeast(0), "Margin each sub-volume reaches into its neighbours"),

      PIPERUN_FIELD("directions", "sample_pairs", "", Stage::Directions, directions.samplePairs, atLeast(0), "Random normal pairs drawn per round"),
      PIPERUN_FIELD("directions", "pair_radius", "m", Stage::Directions, directions.pairRadius, above(0), "Pairs are drawn among points closer than this"),
      PIPERUN_FIELD("directions", "min_pair_angle_deg", "deg", Stage::Directions, directions.minPairAngleDeg, closedOpen(0, 90), "Pairs with normals closer than this to parallel are skipped"),
      PIPERUN_FIELD("directions", "bandwidth_deg", "deg", Stage::Directions, directions.bandwidthDeg, openClosed(0, 30), "Gaussian kernel width of the mean-shift on the sphere"),
      PIPERUN_FIELD("directions", "merge_angle_deg", "deg", Stage::Directions, directions.mergeAngleDeg, closedOpen(0, 90), "Modes (and refined directions) closer than this are one direction"),
      PIPERUN_FIELD("directions", "min_support", "", Stage::Directions, directions.minSupport, closed(0, 1), "A mode must attract at least this share of the round's drawn pairs"),
      PIPERUN_FIELD("directions", "min_significance", "", Stage::Directions, directions.minSignificance, atLeast(0), "A mode must stand out this many standard deviations on the sphere, and its stripe above the band beside it"),
      PIPERUN_FIELD("directions", "min_stripe_points", "", Stage::Directions, directions.minStripePoints, atLeast(0), "A stripe must hold at least this many of the round's points"),
      PIPERUN_FIELD("directions", "stripe_angle_deg", "deg", Stage::Directions, directions.stripeAngleDeg, openClosed(0, 30), "Stripe half-width: a point belongs when its normal is within this of perpendicular (at most 30)"),
      PIPERUN_FIELD("directions", "stripe_noise_sigmas", "", Stage::Directions, directions.stripeNoiseSigmas, atLeast(0), "The stripe widens to this many standard deviations of the direction's normal noise"),
      PIPERUN_FIELD("directions", "min_spread_ratio", "", Stage::Directions, directions.minSpreadRatio, atLeast(0), "Stripe normals must spread around the axis this many times more than they stray from perpendicular"),
      PIPERUN_FIELD("directions", "max_rounds", "", Stage::Directions, directions.maxRounds, atLeast(0), "Repeat on points in no stripe at most this many times"),

      PIPERUN_FIELD("placement", "min_radius", "m", Stage::Placement, placement.minRadius, above(0), "Smallest pipe radius searched"),
      PIPERUN_FIELD("placement", "max_radius", "m", Stage::Placement, placement.maxRadius, above(0), "Largest pipe radius searched"),
      PIPERUN_FIELD("placement", "pairs_per_point", "", Stage::Placement, placement.pairsPerPoint, atLeast(1), "Partners drawn per stripe point and neighbourhood scale for circle candidates"),
      PIPERUN_FIELD("placement", "min_pair_angle_deg", "deg", Stage::Placement, placement.minPairAngleDeg, closedOpen(0, 90), "Pairs whose normals are closer than this to parallel are skipped"),
      PIPERUN_FIELD("placement", "radius_agreement", "", Stage::Placement, placement.radiusAgreement, atLeast(0), "A pair's two centre distances may differ by this share of the radius (min 2 mm)"),
      PIPERUN_FIELD("placement", "center_bandwidth", "m", Stage::Placement, placement.centerBandwidth, above(0), "Mean-shift kernel width for the circle centre"),
      PIPERUN_FIELD("placement", "radius_bandwidth", "m", Stage::Placement, placement.radiusBandwidth, above(0), "Mean-shift kernel width for the radius"),
      PIPERUN_FIELD("placement", "min_candidates", "", Stage::Placement, placement.minCandidates, atLeast(1), "A circle needs at least this many candidates in its mode..."),
      PIPERUN_FIELD("placement", "min_joined_candidates", "", Stage::Placement, placement.minJoinedCandidates, atLeast(0), "...or this many (0: none) when its pipe takes a joint (pipes that take none are left out), with 3x min_candidate_share and an unwidened band"),
      PIPERUN_FIELD("placement", "inlier_distance", "m", Stage::Placement, placement.inlierDistance, above(0), "Inliers lie within this of the cylinder surface (widened on noisy scans, up to 3x)"),
      PIPERUN_FIELD("placement", "inlier_normal_angle_deg", "deg", Stage::Placement, placement.inlierNormalAngleDeg, openClosed(0, 90), "Inliers' normals (re-estimated in the projection plane; a scan column's across the columns beside it) lie within this of the radial direction"),
      PIPERUN_FIELD("placement", "min_inliers", "", Stage::Placement, placement.minInliers, atLeast(3), "Cylinders with fewer inliers are dropped..."),
      PIPERUN_FIELD("placement", "min_joined_inliers", "", Stage::Placement, placement.minJoinedInliers, atLeast(0), "...or this many (0: none) when their pipe takes a joint (pipes that take none are left out)"),
      PIPERUN_FIELD("placement", "min_candidate_share", "", Stage::Placement, placement.minCandidateShare, atLeast(0), "A circle's mode must hold at least this many candidates per inlier"),
      PIPERUN_FIELD("placement", "max_shell_share", "", Stage::Placement, placement.maxShellShare, atLeast(0), "Points just outside the inlier band, as a share of inliers (box edges fail)"),
      PIPERUN_FIELD("placement", "max_out_of_round", "", Stage::Placement, placement.maxOutOfRound, atLeast(0), "Systematic offset around the axis, times the radius, at least 1 mm unless the fit needs normals across scan columns (square posts fail); twice that over every point in the band"),
      PIPERUN_FIELD("placement", "refine_iterations", "", Stage::Placement, placement.refineIterations, atLeast(1), "Gauss-Newton iterations of the least-squares refinement"),

      PIPERUN_FIELD("extents", "section_length", "m", Stage::Extents, extents.sectionLength, atLeast(kMinSectionLength), "Axial section length"),
      PIPERUN_FIELD("extents", "min_points_per_metre", "1/m", Stage::Extents, extents.minPointsPerMetre, atLeast(0), "Axis coverage: points per metre a section needs (0: automatic)"),
      PIPERUN_FIELD("extents", "min_density_ratio", "", Stage::Extents, extents.minDensityRatio, closed(0, 1), "Automatic axis coverage: share of the cylinder's median section density"),
      PIPERUN_FIELD("extents", "density_window", "m", Stage::Extents, extents.densityWindow, atLeast(0), "...of the sections within this distance along the axis, when sparser than the whole cylinder"),
      PIPERUN_FIELD("extents", "min_arc_deg", "deg", Stage::Extents, extents.minArcDeg, closed(0, 360), "Cross-section coverage: angle around the axis a section (pooled to 6 points) must span"),
      PIPERUN_FIELD("extents", "closing_sections", "", Stage::Extents, extents.closingSections, atLeast(0), "1-D closing fills gaps up to this many sections; a run's end goes back over single stray points while its last this many sections hold points in under 35 % of them"),
      PIPERUN_FIELD("extents", "bridge_sections", "", Stage::Extents, extents.bridgeSections, atLeast(0), "...and gaps up to this many between runs at least as long as the gap"),
      PIPERUN_FIELD("extents", "opening_sections", "", Stage::Extents, extents.openingSections, atLeast(0), "1-D opening drops pieces shorter than this many sections"),
      PIPERUN_FIELD("extents", "min_confidence", "", Stage::Extents, extents.minConfidence, closed(0, 1), "Pieces where fewer than this share of the sections passed both coverage tests are opened again at their longest gaps; the part with most inliers stays when it keeps the share and holds over half of them"),
      PIPERUN_FIELD("extents", "min_part_points", "", Stage::Extents, extents.minPartPoints, atLeast(0), "...and at least this many"),
      PIPERUN_FIELD("extents", "min_length", "m", Stage::Extents, extents.minLength, atLeast(0), "Pipes shorter than this are dropped"),

      PIPERUN_FIELD("merge", "max_angle_deg", "deg", Stage::Merge, merge.maxAngleDeg, closedOpen(0, 90), "Pieces merge when their axes are at most this far from parallel"),
      PIPERUN_FIELD("merge", "max_axis_distance", "", Stage::Merge, merge.maxAxisDistance, atLeast(0), "...the shorter piece's ends at most this x the smaller radius off the longer one's axis (min 1 cm)"),
      PIPERUN_FIELD("merge", "max_radius_difference", "", Stage::Merge, merge.maxRadiusDifference, closed(0, 1), "...their radii within this share of the larger (min 3 mm)"),
      PIPERUN_FIELD("merge", "max_gap", "m", Stage::Merge, merge.maxGap, atLeast(0), "...and they overlap or leave at most this gap"),
      PIPERUN_FIELD("merge", "max_extension", "m", Stage::Merge, merge.maxExtension, atLeast(0), "Merged pipes' ends carry on over surface points this far at a time, again while they carry the whole way (0: off)"),
      PIPERUN_FIELD("merge", "extension_normal_angle_deg", "deg", Stage::Merge, merge.extensionNormalAngleDeg, closed(0, 90), "...points whose normals are this close to radial"),
      PIPERUN_FIELD("merge", "extension_bridge_sections", "", Stage::Merge, merge.extensionBridgeSections, atLeast(0), "...across gaps up to this many 4 cm sections when the run beyond is at least as long"),

      PIPERUN_FIELD("joints", "search_diameters", "", Stage::Joints, joints.searchDiameters, atLeast(0), "An end looks for partners within this many diameters of the larger pipe (an elbow's two ends together twice that)"),
      PIPERUN_FIELD("joints", "min_search_distance", "m", Stage::Joints, joints.minSearchDistance, atLeast(0), "...and at least this far"),
      PIPERUN_FIELD("joints", "max_skew_radii", "", Stage::Joints, joints.maxSkewRadii, atLeast(0), "Centre lines may miss each other (co-planarity, collinearity) by this many radii"),
      PIPERUN_FIELD("joints", "min_skew_distance", "m", Stage::Joints, joints.minSkewDistance, atLeast(0), "...and at least this distance"),
      PIPERUN_FIELD("joints", "min_radius_ratio", "", Stage::Joints, joints.minRadiusRatio, closed(0, 1), "Elbows and boundary joints need radii (smaller / larger) at least this close"),
      PIPERUN_FIELD("joints", "max_branch_ratio", "", Stage::Joints, joints.maxBranchRatio, above(0), "A tee's branch radius is at most this x its main pipe's"),
      PIPERUN_FIELD("joints", "max_boundary_angle_deg", "deg", Stage::Joints, joints.maxBoundaryAngleDeg, closedOpen(0, 90), "Ends continuing each other within this angle make a boundary joint"),
      PIPERUN_FIELD("joints", "max_boundary_gap_diameters", "", Stage::Joints, joints.maxBoundaryGapDiameters, atLeast(0), "A boundary joint bridges at most this many diameters (at least min_search_distance)"),
      PIPERUN_FIELD("joints", "min_elbow_angle_deg", "deg", Stage::Joints, joints.minElbowAngleDeg, closedOpen(0, 180), "Smallest bend angle of an elbow"),
      PIPERUN_FIELD("joints", "max_elbow_angle_deg", "deg", Stage::Joints, joints.maxElbowAngleDeg, open(0, 180), "Largest bend angle of an elbow"),
      PIPERUN_FIELD("joints", "min_tee_angle_deg", "deg", Stage::Joints, joints.minTeeAngleDeg, closed(0, 90), "A branch meets its main pipe at least this far from parallel"),
      PIPERUN_FIELD("joints", "min_bend_radii", "", Stage::Joints, joints.minBendRadii, atLeast(1), "Elbow major radius voted from this many pipe radii..."),
      PIPERUN_FIELD("joints", "max_bend_radii", "", Stage::Joints, joints.maxBendRadii, atLeast(1), "...up to this many"),
      PIPERUN_FIELD("joints", "min_pipe_diameters", "", Stage::Joints, joints.minPipeDiameters, atLeast(0), "Shorter pipes are fragments: no joints, absorbed when they lie on an elbow (a longer pipe on a confident elbow's arc waits for it and goes too); a pipe that takes no joint has its confidence scaled by its length under twice this, so a jointless fragment is proposed"),
      PIPERUN_FIELD("joints", "support_distance", "m", Stage::Joints, joints.supportDistance, above(0), "Points within this of a joint's surface support it"),
      PIPERUN_FIELD("joints", "accept_confidence", "", Stage::Joints, joints.acceptConfidence, atLeast(0), "Joints with at least this confidence are accepted, the others proposed (above 1: all proposed, for review)"),
      PIPERUN_FIELD("joints", "max_completion_length", "m", Stage::Joints, joints.maxCompletionLength, atLeast(0), "Ends no accepted joint took look for a missed pipe beyond an elbow, and pipes for a missed branch, up to this long (one reaching it carries on over its points when they stop within 0.3 m more; 0: both off, and so are the search for the leg beyond a gentle bend that one pipe was fitted across and the legs between two bends, seen or hidden)"),
      PIPERUN_FIELD("joints", "min_completion_points", "", Stage::Joints, joints.minCompletionPoints, atLeast(0), "A completed pipe needs this many points on its surface..."),
      PIPERUN_FIELD("joints", "min_completion_coverage", "", Stage::Joints, joints.minCompletionCoverage, closed(0, 1), "...in at least this share of its sections (a short leg between two parallel pipes, half of each)"),
      PIPERUN_FIELD("joints", "min_completion_bend_deg", "deg", Stage::Joints, joints.minCompletionBendDeg, closedOpen(0, 180), "...and turns at least this far from the end's axis"),
      PIPERUN_FIELD("joints", "min_branch_radius", "m", Stage::Joints, joints.minBranchRadius, atLeast(0), "Pipes look along their body for a missed branch (checked as a completed pipe) from this radius up to their own (0: off)"),
      PIPERUN_FIELD("joints", "occluded_search_diameters", "", Stage::Joints, joints.occludedSearchDiameters, atLeast(0), "Two ends no joint took look this far for a proposed elbow across a hidden corner, when its bridged stretches cross no pipe and hold no points near their axes (at most search_diameters: off)"),
      PIPERUN_FIELD("joints", "max_thin_stretch", "m", Stage::Joints, joints.maxThinStretch, atLeast(0), "An end no joint took makes a proposed elbow with a pipe whose end faces its corner from up to this far, when that pipe was seen running on thinly to the corner (half its 25 cm sections hold a point on its surface), or hardly or not at all where the two centre lines meet within a quarter radius (0: off)"),
  };
  return table;
}

#undef PIPERUN_FIELD

std::string fullKey(const Field& field) {
  return field.section[0] ? std::string(field.section) + "." + field.key : std::string(field.key);
}

ordered_json valueJson(const FieldRef& ref) {
  return std::visit(
      [](auto* value) {
        if constexpr (std::is_same_v<std::remove_pointer_t<decltype(value)>, UpAxis>) {
          return ordered_json(toString(*value));
        } else {
          return ordered_json(*value);
        }
      },
      ref);
}

// Sets a field from JSON; false when the JSON value has the wrong type.
bool assign(const FieldRef& ref, const ordered_json& value) {
  return std::visit(
      [&](auto* target) {
        using T = std::remove_pointer_t<decltype(target)>;
        if constexpr (std::is_same_v<T, UpAxis>) {
          if (!value.is_string()) return false;
          try {
            *target = upAxisFromString(value.get<std::string>());
          } catch (const std::invalid_argument&) {
            return false;
          }
          return true;
        } else if constexpr (std::is_same_v<T, bool>) {
          if (!value.is_boolean()) return false;
        } else if constexpr (std::is_same_v<T, double>) {
          if (!value.is_number()) return false;
        } else if constexpr (std::is_same_v<T, std::uint64_t>) {
          if (!value.is_number_unsigned()) return false;
        } else {
          if (!value.is_number_integer()) return false;
          const auto wide = value.get<std::int64_t>();
          if (wide < std::numeric_limits<int>::min() || wide > std::numeric_limits<int>::max()) return false;
        }
        *target = value.get<T>();
        return true;
      },
      ref);
}

std::string typeName(const FieldRef& ref) {
  return std::visit(
      [](auto* target) -> std::string {
        using T = std::remove_pointer_t<decltype(target)>;
        if constexpr (std::is_same_v<T, bool>) return "true or false";
        if constexpr (std::is_same_v<T, UpAxis>) {
          std::string names;
          for (const std::string& name : upAxisNames()) names += (names.empty() ? "\"" : ", \"") + name + "\"";
          return "one of " + names;
        }
        if constexpr (std::is_same_v<T, double>) return "a number";
        if constexpr (std::is_same_v<T, std::uint64_t>) return "a non-negative integer";
        return "an integer";
      },
      ref);
}

/// The field's value as a number; nullopt for true/false and axis fields.
std::optional<double> numericValue(const FieldRef& ref) {
  return std::visit(
      [](auto* value) -> std::optional<double> {
        using T = std::remove_pointer_t<decltype(value)>;
        if constexpr (std::is_same_v<T, bool> || std::is_same_v<T, UpAxis>) {
          return std::nullopt;
        } else {
          return static_cast<double>(*value);
        }
      },
      ref);
}

/// What the field's range asks ("must be > 0 m, not -1.0"); empty when its value lies in it.
std::string rangeProblem(const Field& field, PipelineParams& params) {
  const std::optional<double> value = numericValue(field.ref(params));
  if (!value || field.range.contains(*value)) return "";
  const std::string unit = field.unit[0] ? std::string(" ") + field.unit : "";
  const bool oneSided = field.range.high == kUnbounded;
  const FieldRef ref = field.ref(params);
  const std::string shown = std::holds_alternative<double*>(ref) ? numberText(*value) : valueJson(ref).dump();
  return std::string(oneSided ? "must be " : "must lie in ") + field.range.text() + unit + ", not " + shown;
}

}  // namespace

std::vector<ParamDescription> describeParams() {
  PipelineParams defaults;
  std::vector<ParamDescription> descriptions;
  for (const Field& field : fields()) {
    descriptions.push_back(
        {fullKey(field), valueJson(field.ref(defaults)).dump(), field.unit, field.range.text(), field.description});
  }
  return descriptions;
}

std::string paramsToJson(const PipelineParams& params, int indent) {
  PipelineParams copy = params;
  ordered_json document = ordered_json::object();
  for (const Field& field : fields()) {
    if (field.section[0]) {
      document[field.section][field.key] = valueJson(field.ref(copy));
    } else {
      document[field.key] = valueJson(field.ref(copy));
    }
  }
  return document.dump(indent) + "\n";
}

PipelineParams paramsFromJson(const std::string& text, const std::filesystem::path& source, const PipelineParams& base) {
  const ordered_json document = parseJsonText<ordered_json>(text, source);
  if (!document.is_object()) throw InputError(source, "/", "expected a JSON object of parameters");
  PipelineParams params = base;
  const auto findField = [](const std::string& section, const std::string& key) -> const Field* {
    for (const Field& field : fields()) {
      if (section == field.section && key == field.key) return &field;
    }
    return nullptr;
  };
  const auto setFrom = [&](const Field& field, const ordered_json& value, const std::string& pointer) {
    if (!assign(field.ref(params), value)) {
      throw InputError(source, pointer, std::string("expected ") + typeName(field.ref(params)));
    }
    const std::string problem = rangeProblem(field, params);
    if (!problem.empty()) throw InputError(source, pointer, problem);
  };
  for (const auto& [name, value] : document.items()) {
    if (value.is_object()) {
      for (const auto& [key, item] : value.items()) {
        const Field* field = findField(name, key);
        if (!field) throw InputError(source, "/" + name + "/" + key, "unknown parameter (see `piperun params`)");
        setFrom(*field, item, "/" + name + "/" + key);
      }
    } else {
      const Field* field = findField("", name);
      if (!field) throw InputError(source, "/" + name, "unknown parameter (see `piperun params`)");
      setFrom(*field, value, "/" + name);
    }
  }
  return params;
}

PipelineParams readParams(const std::filesystem::path& path, const PipelineParams& base) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open the parameter file");
  std::ostringstream text;
  text << in.rdbuf();
  return paramsFromJson(text.str(), path, base);
}

std::optional<Stage> firstChangedStage(const PipelineParams& a, const PipelineParams& b) {
  PipelineParams left = a;
  PipelineParams right = b;
  std::optional<Stage> earliest;
  for (const Field& field : fields()) {
    if (!field.stage || valueJson(field.ref(left)) == valueJson(field.ref(right))) continue;
    if (!earliest || static_cast<int>(*field.stage) < static_cast<int>(*earliest)) earliest = field.stage;
  }
  return earliest;
}

void setParam(PipelineParams& params, const std::string& assignment) {
  const auto equals = assignment.find('=');
  if (equals == std::string::npos) {
    throw std::invalid_argument("expected key=value, got '" + assignment + "'");
  }
  const std::string key = assignment.substr(0, equals);
  const std::string text = assignment.substr(equals + 1);
  for (const Field& field : fields()) {
    if (fullKey(field) != key) continue;
    ordered_json value;
    try {
      value = ordered_json::parse(text);
    } catch (const ordered_json::exception&) {  // not JSON, or a number beyond a double's range
      // A word is its own value where a word is wanted: up=y as well as up="y".
      if (!std::holds_alternative<UpAxis*>(field.ref(params))) {
        throw std::invalid_argument("parameter " + key + ": '" + text + "' is not " + typeName(field.ref(params)));
      }
      value = text;
    }
    PipelineParams changed = params;
    if (!assign(field.ref(changed), value)) {
      throw std::invalid_argument("parameter " + key + ": '" + text + "' is not " + typeName(field.ref(params)));
    }
    const std::string problem = rangeProblem(field, changed);
    if (!problem.empty()) throw std::invalid_argument("parameter " + key + " " + problem);
    params = changed;
    return;
  }
  throw std::invalid_argument("unknown parameter '" + key + "' (see `piperun params`)");
}

void validateParams(const PipelineParams& params) {
  PipelineParams copy = params;  // the table reaches the members through non-const pointers
  std::vector<std::string> problems;
  for (const Field& field : fields()) {
    const std::string problem = rangeProblem(field, copy);
    if (!problem.empty()) problems.push_back(fullKey(field) + " " + problem);
  }
  // Pairs of parameters that bound each other.
  const auto ordered = [&](double low, const char* lowKey, double high, const char* highKey, bool strictly) {
    if (strictly ? low < high : low <= high) return;
    problems.push_back(std::string(lowKey) + " (" + numberText(low) + ") must be " + (strictly ? "below " : "at most ") +
                       highKey + " (" + numberText(high) + ")");
  };
  ordered(params.placement.minRadius, "placement.min_radius", params.placement.maxRadius, "placement.max_radius", true);
  ordered(params.preprocess.tileOverlap, "preprocess.tile_overlap", params.preprocess.tileSize, "preprocess.tile_size", true);
  ordered(params.joints.minElbowAngleDeg, "joints.min_elbow_angle_deg", params.joints.maxElbowAngleDeg,
          "joints.max_elbow_angle_deg", true);
  ordered(params.joints.minBendRadii, "joints.min_bend_radii", params.joints.maxBendRadii, "joints.max_bend_radii", false);
  if (problems.empty()) return;
  std::string message = "invalid parameters: ";
  for (std::size_t i = 0; i < problems.size(); ++i) message += (i > 0 ? "; " : "") + problems[i];
  throw std::invalid_argument(message);
}

}  // namespace piperun
