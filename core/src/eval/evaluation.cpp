#include "piperun/eval/evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <tuple>
#include <unordered_map>

namespace piperun {

namespace {

struct AxisSample {
  Eigen::Vector3d position;
  double radius;
};

std::vector<AxisSample> sampleNetwork(const PipeNetwork& network, double step, bool skipDiscarded, bool pipesOnly) {
  std::vector<AxisSample> samples;
  const auto add = [&](const std::vector<Eigen::Vector3d>& polyline, double radius) {
    for (const auto& p : samplePolyline(polyline, step)) samples.push_back({p, radius});
  };
  for (const auto& pipe : network.pipes) {
    if (skipDiscarded && pipe.status == PipeStatus::Deleted) continue;
    add({pipe.start, pipe.end}, pipe.radius);
  }
  if (pipesOnly) return samples;
  for (const auto& joint : network.joints) {
    if (skipDiscarded && joint.status == JointStatus::Rejected) continue;
    add(joint.axis, joint.radius);
  }
  return samples;
}

// Uniform hash grid over samples, for fixed-radius neighbour queries.
class SampleGrid {
 public:
  SampleGrid(const std::vector<AxisSample>& samples, double cellSize) : samples_(samples), cell_(cellSize) {
    for (std::size_t i = 0; i < samples.size(); ++i) cells_[key(cellOf(samples[i].position))].push_back(i);
  }

  /// Calls visit(index) for every sample within `radius` (≤ the cell size) of `p`.
  template <class Visit>
  void forEachNear(const Eigen::Vector3d& p, double radius, Visit&& visit) const {
    const Eigen::Vector3i center = cellOf(p);
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          const auto found = cells_.find(key(center + Eigen::Vector3i(dx, dy, dz)));
          if (found == cells_.end()) continue;
          for (std::size_t index : found->second) {
            if ((samples_[index].position - p).squaredNorm() <= radius * radius) visit(index);
          }
        }
      }
    }
  }

 private:
  Eigen::Vector3i cellOf(const Eigen::Vector3d& p) const { return (p / cell_).array().floor().cast<int>(); }
  static std::uint64_t key(const Eigen::Vector3i& c) {
    const auto part = [](int v) { return static_cast<std::uint64_t>(static_cast<std::uint32_t>(v) & 0x1FFFFFu); };
    return part(c.x()) | (part(c.y()) << 21) | (part(c.z()) << 42);
  }

  const std::vector<AxisSample>& samples_;
  double cell_;
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> cells_;
};

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  if (values.size() % 2 == 1) return *middle;
  const double upper = *middle;
  const double lower = *std::max_element(values.begin(), middle);
  return 0.5 * (lower + upper);
}

// Greedy one-to-one matching of joints of one type, closest pairs first (deterministic).
void matchJoints(const PipeNetwork& truth, const std::vector<const Joint*>& predicted, JointType type,
                 const EvaluationParams& params, std::vector<char>& predictedMatched, int& truthCount,
                 int& foundCount, std::vector<double>& bendErrors) {
  std::vector<std::tuple<double, std::size_t, std::size_t>> pairs;  // distance, truth index, predicted index
  std::vector<const Joint*> truthJoints;
  for (const auto& joint : truth.joints) {
    if (joint.type == type) truthJoints.push_back(&joint);
  }
  truthCount = static_cast<int>(truthJoints.size());
  for (std::size_t t = 0; t < truthJoints.size(); ++t) {
    const double limit = std::max(params.jointMinDistance, params.jointRadiusFactor * truthJoints[t]->radius);
    const Eigen::Vector3d position = truthJoints[t]->position();
    for (std::size_t p = 0; p < predicted.size(); ++p) {
      if (predicted[p]->type != type) continue;
      const double distance = (predicted[p]->position() - position).norm();
      if (distance <= limit) pairs.emplace_back(distance, t, p);
    }
  }
  std::sort(pairs.begin(), pairs.end());
  std::vector<char> truthMatched(truthJoints.size(), 0);
  foundCount = 0;
  for (const auto& [distance, t, p] : pairs) {
    if (truthMatched[t] || predictedMatched[p]) continue;
    truthMatched[t] = 1;
    predictedMatched[p] = 1;
    ++foundCount;
    if (type == JointType::Elbow && truthJoints[t]->bendRadius > 0.0) {
      bendErrors.push_back(std::fabs(predicted[p]->bendRadius - truthJoints[t]->bendRadius) / truthJoints[t]->bendRadius);
    }
  }
}

}  // namespace

EvaluationResult evaluateNetwork(const PipeNetwork& truth, const PipeNetwork& predicted, const EvaluationParams& params) {
  if (!(params.sampleStep > 0.0)) throw std::invalid_argument("evaluation sample step must be positive");
  const auto truthSamples = sampleNetwork(truth, params.sampleStep, false, params.pipesOnly);
  const auto predictedSamples = sampleNetwork(predicted, params.sampleStep, true, params.pipesOnly);

  const auto toleranceOf = [&](const AxisSample& sample) {
    if (params.fixedTolerance > 0.0) return params.fixedTolerance;
    return std::max(params.minTolerance, params.radiusFactor * sample.radius);
  };
  double maxTolerance = params.fixedTolerance > 0.0 ? params.fixedTolerance : params.minTolerance;
  for (const auto& sample : truthSamples) maxTolerance = std::max(maxTolerance, toleranceOf(sample));

  EvaluationResult result;
  result.truthSamples = truthSamples.size();
  result.predictedSamples = predictedSamples.size();

  // Precision: a predicted sample counts when some truth sample has it within that sample's tolerance.
  const SampleGrid truthGrid(truthSamples, maxTolerance);
  for (const auto& sample : predictedSamples) {
    bool matched = false;
    truthGrid.forEachNear(sample.position, maxTolerance, [&](std::size_t t) {
      if ((truthSamples[t].position - sample.position).norm() <= toleranceOf(truthSamples[t])) matched = true;
    });
    if (matched) ++result.matchedPredictedSamples;
  }

  // Recall and radius error: each truth sample looks for predicted samples within its tolerance.
  const SampleGrid predictedGrid(predictedSamples, maxTolerance);
  std::vector<double> radiusErrors;
  for (const auto& sample : truthSamples) {
    const double tolerance = toleranceOf(sample);
    double nearest = std::numeric_limits<double>::infinity();
    double nearestRadius = 0.0;
    predictedGrid.forEachNear(sample.position, tolerance, [&](std::size_t p) {
      const double distance = (predictedSamples[p].position - sample.position).norm();
      if (distance < nearest) {
        nearest = distance;
        nearestRadius = predictedSamples[p].radius;
      }
    });
    if (std::isfinite(nearest)) {
      ++result.matchedTruthSamples;
      radiusErrors.push_back(std::fabs(nearestRadius - sample.radius));
    }
  }

  if (truthSamples.empty() && predictedSamples.empty()) {
    result.precision = result.recall = 1.0;
  } else {
    result.precision = predictedSamples.empty()
                           ? 0.0
                           : static_cast<double>(result.matchedPredictedSamples) / static_cast<double>(predictedSamples.size());
    result.recall = truthSamples.empty()
                        ? 0.0
                        : static_cast<double>(result.matchedTruthSamples) / static_cast<double>(truthSamples.size());
  }
  const double sum = result.precision + result.recall;
  result.f1 = sum > 0.0 ? 2.0 * result.precision * result.recall / sum : 0.0;
  result.radiusErrorMedian = median(radiusErrors);

  std::vector<const Joint*> predictedJoints;
  for (const auto& joint : predicted.joints) {
    if (joint.status != JointStatus::Rejected) predictedJoints.push_back(&joint);
  }
  std::vector<char> predictedMatched(predictedJoints.size(), 0);
  std::vector<double> bendErrors;
  int ignoredTruth = 0;
  int ignoredFound = 0;
  matchJoints(truth, predictedJoints, JointType::Elbow, params, predictedMatched, result.truthElbows,
              result.foundElbows, bendErrors);
  matchJoints(truth, predictedJoints, JointType::Tee, params, predictedMatched, result.truthTees, result.foundTees,
              bendErrors);
  matchJoints(truth, predictedJoints, JointType::Boundary, params, predictedMatched, ignoredTruth, ignoredFound,
              bendErrors);
  // A boundary joint that bridges a gap along the truth (an occlusion of a continuous pipe) is
  // right even though the truth, having no gaps, lists no such joint.
  for (std::size_t p = 0; p < predictedJoints.size(); ++p) {
    if (predictedMatched[p] || predictedJoints[p]->type != JointType::Boundary) continue;
    bool alongTruth = true;
    for (const auto& sample : samplePolyline(predictedJoints[p]->axis, params.sampleStep)) {
      bool matched = false;
      truthGrid.forEachNear(sample, maxTolerance, [&](std::size_t t) {
        if ((truthSamples[t].position - sample).norm() <= toleranceOf(truthSamples[t])) matched = true;
      });
      alongTruth = alongTruth && matched;
    }
    predictedMatched[p] = alongTruth ? 1 : 0;
  }
  result.predictedJoints = static_cast<int>(predictedJoints.size());
  result.spuriousJoints =
      static_cast<int>(std::count(predictedMatched.begin(), predictedMatched.end(), static_cast<char>(0)));
  result.bendRadiusErrorMedian = median(bendErrors);
  return result;
}

std::string formatEvaluation(const EvaluationResult& result) {
  char line[320];
  std::snprintf(line, sizeof line,
                "precision=%.3f recall=%.3f f1=%.3f radius_err_mm=%.1f elbows=%d/%d tees=%d/%d "
                "spurious_joints=%d/%d bend_radius_err=%.3f",
                result.precision, result.recall, result.f1, result.radiusErrorMedian * 1000.0, result.foundElbows,
                result.truthElbows, result.foundTees, result.truthTees, result.spuriousJoints, result.predictedJoints,
                result.bendRadiusErrorMedian);
  return line;
}

}  // namespace piperun
