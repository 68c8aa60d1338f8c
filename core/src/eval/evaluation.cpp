#include "piperun/eval/evaluation.h"

#include "piperun/edit/nominal_sizes.h"
#include "piperun/pipe_measures.h"

#include "points_near.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <tuple>
#include <unordered_map>
#include <utility>

namespace piperun {

namespace {

struct AxisSample {
  Eigen::Vector3d position;
  double radius;
};

/// The samples of one element, consecutive in the sample list.
struct ElementSamples {
  int id = 0;
  std::size_t first = 0, last = 0;
  bool straight = false;  ///< Sampled from a two-point polyline: evenly from first to last.
  bool proposed = false;  ///< Its review status is proposed (else accepted).
};

struct NetworkSamples {
  std::vector<AxisSample> samples;
  std::vector<ElementSamples> elements;
  std::unordered_map<int, std::size_t> elementOf;  ///< Index into `elements` by element id.
};

NetworkSamples sampleNetwork(const PipeNetwork& network, double step, bool skipDiscarded, bool pipesOnly) {
  NetworkSamples sampled;
  const auto add = [&](int id, const std::vector<Eigen::Vector3d>& polyline, double radius, bool proposed) {
    const std::size_t first = sampled.samples.size();
    for (const auto& p : samplePolyline(polyline, step)) sampled.samples.push_back({p, radius});
    sampled.elementOf.emplace(id, sampled.elements.size());
    sampled.elements.push_back({id, first, sampled.samples.size(), polyline.size() == 2, proposed});
  };
  for (const auto& pipe : network.pipes) {
    if (skipDiscarded && pipe.status == PipeStatus::Deleted) continue;
    add(pipe.id, {pipe.start, pipe.end}, pipe.radius, pipe.status == PipeStatus::Proposed);
  }
  if (pipesOnly) return sampled;
  for (const auto& joint : network.joints) {
    if (skipDiscarded && joint.status == JointStatus::Rejected) continue;
    add(joint.id, joint.axis, joint.radius, joint.status == JointStatus::Proposed);
  }
  return sampled;
}

/// What a labelled scan shows of the truth.
struct ScanCoverage {
  std::vector<char> observable;             ///< Per truth sample.
  std::unordered_map<int, int> pointsOf;    ///< Labelled points per sampled truth element (pipes always).
};

/// Flags the truth samples the scan shows: each labelled point counts for the nearest sample of
/// its element, and a sample is observable when its window along the element holds enough points.
ScanCoverage scanCoverage(const NetworkSamples& truth, const PointCloud& scan, const EvaluationParams& params) {
  ScanCoverage coverage;
  std::vector<int> pointsAt(truth.samples.size(), 0);
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const auto found = truth.elementOf.find(scan.labels[i]);
    if (found == truth.elementOf.end()) continue;
    const ElementSamples& element = truth.elements[found->second];
    const Eigen::Vector3d p = scan.worldPosition(i);
    std::size_t nearest = element.first;
    const std::size_t count = element.last - element.first;
    if (element.straight && count > 1) {
      const Eigen::Vector3d a = truth.samples[element.first].position, b = truth.samples[element.last - 1].position;
      const double t = std::clamp((p - a).dot(b - a) / std::max((b - a).squaredNorm(), 1e-300), 0.0, 1.0);
      nearest += static_cast<std::size_t>(std::lround(t * static_cast<double>(count - 1)));
    } else {
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t s = element.first; s < element.last; ++s) {
        const double d = (truth.samples[s].position - p).squaredNorm();
        if (d < best) best = d, nearest = s;
      }
    }
    ++pointsAt[nearest];
    ++coverage.pointsOf[element.id];
  }
  const auto reach = static_cast<std::size_t>(std::lround(params.observableWindow / params.sampleStep));
  coverage.observable.assign(truth.samples.size(), 0);
  for (const ElementSamples& element : truth.elements) {
    for (std::size_t s = element.first; s < element.last; ++s) {
      const std::size_t from = s - std::min(reach, s - element.first), to = std::min(element.last, s + reach + 1);
      int inWindow = 0;
      for (std::size_t w = from; w < to; ++w) inWindow += pointsAt[w];
      coverage.observable[s] = inWindow >= params.observableMinPoints;
    }
  }
  return coverage;
}

/// How far from a truth joint the points of its pipes show its corner (EvaluationParams::cornerMinDistance).
double cornerReach(const Joint& joint, const EvaluationParams& params) {
  return std::max(params.cornerMinDistance, params.cornerRadii * joint.radius);
}

/// Per truth joint of `truth` (elbows and tees; none for boundary joints), the labelled points of
/// each of its pipes within its cornerReach of its position, from one pass over the scan.
std::unordered_map<const Joint*, std::vector<int>> pointsNearCorners(const PipeNetwork& truth,
                                                                     const EvaluationParams& params,
                                                                     const PointCloud& scan) {
  std::unordered_map<const Joint*, std::vector<int>> counts;
  struct Slot {  // A pipe of a joint: where the joint is, how far its corner reaches, its count.
    Eigen::Vector3d position;
    double reach;
    int* count;
  };
  for (const Joint& joint : truth.joints) {
    if (joint.type != JointType::Boundary) counts[&joint].assign(joint.pipeIds.size(), 0);
  }
  std::unordered_map<int, std::vector<Slot>> slotsOfPipe;  // By pipe id (the points' label).
  for (auto& [joint, pipeCounts] : counts) {
    for (std::size_t k = 0; k < joint->pipeIds.size(); ++k) {
      slotsOfPipe[joint->pipeIds[k]].push_back(Slot{joint->position(), cornerReach(*joint, params), &pipeCounts[k]});
    }
  }
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const auto found = slotsOfPipe.find(scan.labels[i]);
    if (found == slotsOfPipe.end()) continue;
    const Eigen::Vector3d p = scan.worldPosition(i);
    for (const Slot& slot : found->second) {
      if ((p - slot.position).norm() <= slot.reach) ++*slot.count;
    }
  }
  return counts;
}

// Samples in a hash grid, for fixed-radius neighbour queries.
class SampleGrid {
 public:
  SampleGrid(const std::vector<AxisSample>& samples, double cellSize) : samples_(samples), grid_(cellSize) {
    for (std::size_t i = 0; i < samples.size(); ++i) {
      grid_.insert(grid_.cellOf(samples[i].position), static_cast<std::uint32_t>(i));
    }
  }

  /// Calls visit(index) for every sample within `radius` of `p`.
  template <class Visit>
  void forEachNear(const Eigen::Vector3d& p, double radius, Visit&& visit) const {
    grid_.forEachInCube(p, radius, [&](std::uint32_t index) {
      if ((samples_[index].position - p).squaredNorm() <= radius * radius) visit(index);
    });
  }

 private:
  const std::vector<AxisSample>& samples_;
  HashGrid grid_;
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

// Greedy one-to-one matching of joints of one type, closest pairs first (deterministic). Returns the
// truth joints of that type, in truth order, each with the index into `predicted` of its match (-1:
// none).
std::vector<std::pair<const Joint*, int>> matchJoints(const PipeNetwork& truth, const std::vector<const Joint*>& predicted,
                                                      JointType type, const EvaluationParams& params,
                                                      std::vector<char>& predictedMatched) {
  std::vector<std::pair<const Joint*, int>> matches;
  for (const auto& joint : truth.joints) {
    if (joint.type == type) matches.emplace_back(&joint, -1);
  }
  std::vector<std::tuple<double, std::size_t, std::size_t>> pairs;  // distance, truth index, predicted index
  for (std::size_t t = 0; t < matches.size(); ++t) {
    const Joint& joint = *matches[t].first;
    const double limit = std::max(params.jointMinDistance, params.jointRadiusFactor * joint.radius);
    const Eigen::Vector3d position = joint.position();
    // An elbow found where the truth's is but turning as a different fitting (a 90° one found as a
    // 45° one: the chord of its bend) is not that elbow.
    const auto truthBend = type == JointType::Elbow ? bendOf(joint.axis) : std::nullopt;
    const auto turnsAlike = [&](const Joint& found) {
      if (!truthBend) return true;
      const auto bend = bendOf(found.axis);
      return !bend || std::fabs(bend->angleDegrees() - truthBend->angleDegrees()) <= params.jointMaxTurnDifferenceDeg;
    };
    for (std::size_t p = 0; p < predicted.size(); ++p) {
      if (predicted[p]->type != type) continue;
      const double distance = (predicted[p]->position() - position).norm();
      if (distance <= limit && turnsAlike(*predicted[p])) pairs.emplace_back(distance, t, p);
    }
  }
  std::sort(pairs.begin(), pairs.end());
  for (const auto& [distance, t, p] : pairs) {
    if (matches[t].second >= 0 || predictedMatched[p]) continue;
    matches[t].second = static_cast<int>(p);
    predictedMatched[p] = 1;
  }
  return matches;
}

}  // namespace

EvaluationResult evaluateNetwork(const PipeNetwork& truth, const PipeNetwork& predicted, const EvaluationParams& params,
                                 const PointCloud* labelledScan) {
  if (!(params.sampleStep > 0.0)) throw std::invalid_argument("evaluation sample step must be positive");
  if (labelledScan && !labelledScan->hasLabels()) {
    throw std::invalid_argument("the scan has no labels: generate it with piperun generate --labels");
  }
  const NetworkSamples truthSampled = sampleNetwork(truth, params.sampleStep, false, params.pipesOnly);
  const std::vector<AxisSample>& truthSamples = truthSampled.samples;
  const NetworkSamples predictedSampled = sampleNetwork(predicted, params.sampleStep, true, params.pipesOnly);
  const std::vector<AxisSample>& predictedSamples = predictedSampled.samples;
  const ScanCoverage coverage = labelledScan ? scanCoverage(truthSampled, *labelledScan, params) : ScanCoverage{};
  const std::vector<char>& observable = coverage.observable;

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
  // Also by the review status of the sample's element.
  const SampleGrid truthGrid(truthSamples, maxTolerance);
  for (const ElementSamples& element : predictedSampled.elements) {
    ReviewShare& byStatus = element.proposed ? result.proposedSamples : result.acceptedSamples;
    for (std::size_t p = element.first; p < element.last; ++p) {
      bool matched = false;
      truthGrid.forEachNear(predictedSamples[p].position, maxTolerance, [&](std::size_t t) {
        if ((truthSamples[t].position - predictedSamples[p].position).norm() <= toleranceOf(truthSamples[t])) {
          matched = true;
        }
      });
      ++byStatus.total;
      if (matched) {
        ++result.matchedPredictedSamples;
        ++byStatus.part;
      }
    }
  }

  // Recall and radius error: each truth sample looks for predicted samples within its tolerance.
  const SampleGrid predictedGrid(predictedSamples, maxTolerance);
  std::vector<double> radiusErrors;
  std::vector<char> truthMatched(truthSamples.size(), 0);
  for (std::size_t t = 0; t < truthSamples.size(); ++t) {
    const AxisSample& sample = truthSamples[t];
    const double tolerance = toleranceOf(sample);
    double nearest = std::numeric_limits<double>::infinity();
    double nearestRadius = 0.0;
    // Samples of two elements can coincide (a tee's axis starts on its main's): of those, the one
    // of the truth's nominal size.
    const auto truthSize = [&](double radius) {
      const NominalSizes* sizes = params.nominalSizes;
      return sizes && sizes->nearest(radius).dn == sizes->nearest(sample.radius).dn;
    };
    predictedGrid.forEachNear(sample.position, tolerance, [&](std::size_t p) {
      const double distance = (predictedSamples[p].position - sample.position).norm();
      if (distance < nearest ||
          (distance == nearest && !truthSize(nearestRadius) && truthSize(predictedSamples[p].radius))) {
        nearest = distance;
        nearestRadius = predictedSamples[p].radius;
      }
    });
    if (std::isfinite(nearest)) {
      truthMatched[t] = 1;
      ++result.matchedTruthSamples;
      radiusErrors.push_back(std::fabs(nearestRadius - sample.radius));
      if (truthSize(nearestRadius)) ++result.nominalSizeRight;
    }
    if (!observable.empty() && observable[t]) {
      ++result.observableTruthSamples;
      if (std::isfinite(nearest)) ++result.matchedObservableSamples;
    }
  }
  if (labelledScan) {
    result.observableMeasured = true;
    const auto share = [](std::size_t part, std::size_t whole) {
      return whole > 0 ? static_cast<double>(part) / static_cast<double>(whole) : 0.0;
    };
    result.observableShare = share(result.observableTruthSamples, truthSamples.size());
    result.recallObservable = share(result.matchedObservableSamples, result.observableTruthSamples);
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
  result.nominalMeasured = params.nominalSizes != nullptr;

  std::vector<const Joint*> predictedJoints;
  for (const auto& joint : predicted.joints) {
    if (joint.status != JointStatus::Rejected) predictedJoints.push_back(&joint);
  }
  std::vector<char> predictedMatched(predictedJoints.size(), 0);
  std::vector<double> bendErrors;
  const auto labelledPoints = [&](int element) {
    const auto found = coverage.pointsOf.find(element);
    return found == coverage.pointsOf.end() ? 0 : found->second;
  };
  const auto nearCorners = labelledScan ? pointsNearCorners(truth, params, *labelledScan)
                                        : std::unordered_map<const Joint*, std::vector<int>>{};
  // The share of a truth pipe's samples within `reach` of `position` that the prediction matched:
  // of those the scan shows, or of all when it shows none there (a few scattered points); -1 when
  // the pipe has no sample there.
  const auto foundNear = [&](int pipe, const Eigen::Vector3d& position, double reach) {
    const auto found = truthSampled.elementOf.find(pipe);
    if (found == truthSampled.elementOf.end()) return -1.0;
    const ElementSamples& element = truthSampled.elements[found->second];
    int near = 0, nearMatched = 0, shown = 0, shownMatched = 0;
    for (std::size_t s = element.first; s < element.last; ++s) {
      if ((truthSamples[s].position - position).norm() > reach) continue;
      ++near;
      nearMatched += truthMatched[s];
      if (observable[s]) {
        ++shown;
        shownMatched += truthMatched[s];
      }
    }
    if (shown > 0) return static_cast<double>(shownMatched) / shown;
    return near > 0 ? static_cast<double>(nearMatched) / near : -1.0;
  };
  for (const JointType type : {JointType::Elbow, JointType::Tee, JointType::Boundary}) {
    const auto matches = matchJoints(truth, predictedJoints, type, params, predictedMatched);
    if (type == JointType::Boundary) continue;  // Generated truths list none; a bridged gap is checked below.
    const bool elbow = type == JointType::Elbow;
    for (const auto& [joint, p] : matches) {
      JointOutcome outcome;
      outcome.truthId = joint->id;
      outcome.type = type;
      outcome.position = joint->position();
      outcome.truthBendRadius = joint->bendRadius;
      outcome.pipeIds = joint->pipeIds;
      if (p >= 0) {
        const Joint& match = *predictedJoints[static_cast<std::size_t>(p)];
        outcome.matchedId = match.id;
        outcome.distance = (match.position() - outcome.position).norm();
        outcome.predictedBendRadius = match.bendRadius;
        if (elbow && joint->bendRadius > 0.0) {
          bendErrors.push_back(std::fabs(match.bendRadius - joint->bendRadius) / joint->bendRadius);
        }
      }
      (elbow ? result.truthElbows : result.truthTees) += 1;
      (elbow ? result.foundElbows : result.foundTees) += p >= 0;
      if (labelledScan) {
        for (const int pipe : joint->pipeIds) outcome.pipePoints.push_back(labelledPoints(pipe));
        if (!params.pipesOnly) outcome.ownPoints = labelledPoints(joint->id);
        // Observable: each of its pipes holds enough points.
        if (std::all_of(outcome.pipePoints.begin(), outcome.pipePoints.end(),
                        [&](int points) { return points >= params.observableJointMinPoints; })) {
          (elbow ? result.observableElbows : result.observableTees) += 1;
          (elbow ? result.foundObservableElbows : result.foundObservableTees) += p >= 0;
        }
        outcome.pipePointsNearCorner = nearCorners.at(joint);
        outcome.cornerDistance = cornerReach(*joint, params);
        const bool cornerSeen =
            std::all_of(outcome.pipePointsNearCorner.begin(), outcome.pipePointsNearCorner.end(),
                        [&](int points) { return points >= params.cornerMinPoints; });
        if (cornerSeen) {
          (elbow ? result.cornerSeenElbows : result.cornerSeenTees) += 1;
          (elbow ? result.foundCornerSeenElbows : result.foundCornerSeenTees) += p >= 0;
        }
        for (const int pipe : joint->pipeIds) {
          outcome.pipeFoundNearCorner.push_back(foundNear(pipe, outcome.position, outcome.cornerDistance));
        }
        if (p < 0) {
          const auto& shares = outcome.pipeFoundNearCorner;
          MissCounts& missed = elbow ? result.missedElbows : result.missedTees;
          if (!cornerSeen) {
            outcome.cause = MissCause::Unseen;
            ++missed.unseen;
          } else if (std::any_of(shares.begin(), shares.end(),
                                 [&](double share) { return share < params.cornerFoundShare; })) {
            outcome.cause = MissCause::PipeNotFound;
            ++missed.pipeNotFound;
          } else {
            outcome.cause = MissCause::NotJoined;
            ++missed.notJoined;
          }
        }
      }
      result.jointOutcomes.push_back(std::move(outcome));
    }
  }
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
  for (std::size_t p = 0; p < predictedJoints.size(); ++p) {
    if (predictedMatched[p]) continue;
    const Joint& joint = *predictedJoints[p];
    SpuriousJoint spurious{joint.id, joint.type, joint.status, joint.confidence, joint.position()};
    for (const JointOutcome& outcome : result.jointOutcomes) {
      const double distance = (outcome.position - spurious.position).norm();
      if (spurious.nearestTruthId < 0 || distance < spurious.nearestTruthDistance) {
        spurious.nearestTruthId = outcome.truthId;
        spurious.nearestTruthDistance = distance;
      }
    }
    result.spurious.push_back(spurious);
  }
  result.predictedJoints = static_cast<int>(predictedJoints.size());
  result.spuriousJoints = static_cast<int>(result.spurious.size());
  for (const Joint* joint : predictedJoints) {
    ++(joint->status == JointStatus::Proposed ? result.spuriousProposed : result.spuriousAccepted).total;
  }
  for (const SpuriousJoint& joint : result.spurious) {
    ++(joint.status == JointStatus::Proposed ? result.spuriousProposed : result.spuriousAccepted).part;
  }
  result.bendRadiusErrorMedian = median(bendErrors);
  return result;
}

std::string toString(MissCause cause) {
  switch (cause) {
    case MissCause::None: return "";
    case MissCause::Unseen: return "unseen";
    case MissCause::PipeNotFound: return "pipe_not_found";
    case MissCause::NotJoined: return "not_joined";
  }
  return "";
}

std::string formatEvaluation(const EvaluationResult& result) {
  char line[320];
  std::snprintf(line, sizeof line,
                "precision=%.3f recall=%.3f f1=%.3f radius_err_mm=%.1f elbows=%d/%d tees=%d/%d "
                "spurious_joints=%d/%d bend_radius_err=%.3f",
                result.precision, result.recall, result.f1, result.radiusErrorMedian * 1000.0, result.foundElbows,
                result.truthElbows, result.foundTees, result.truthTees, result.spuriousJoints, result.predictedJoints,
                result.bendRadiusErrorMedian);
  std::string text = line;
  std::snprintf(line, sizeof line,
                " accepted_matched=%zu/%zu proposed_matched=%zu/%zu spurious_accepted=%zu/%zu spurious_proposed=%zu/%zu",
                result.acceptedSamples.part, result.acceptedSamples.total, result.proposedSamples.part,
                result.proposedSamples.total, result.spuriousAccepted.part, result.spuriousAccepted.total,
                result.spuriousProposed.part, result.spuriousProposed.total);
  text += line;
  if (result.nominalMeasured) {
    std::snprintf(line, sizeof line, " nominal_size_right=%zu/%zu", result.nominalSizeRight, result.matchedTruthSamples);
    text += line;
  }
  if (result.observableMeasured) {
    std::snprintf(line, sizeof line,
                  " observable=%.3f recall_observable=%.3f observable_elbows=%d/%d observable_tees=%d/%d"
                  " corner_seen_elbows=%d/%d corner_seen_tees=%d/%d",
                  result.observableShare, result.recallObservable, result.foundObservableElbows,
                  result.observableElbows, result.foundObservableTees, result.observableTees,
                  result.foundCornerSeenElbows, result.cornerSeenElbows, result.foundCornerSeenTees,
                  result.cornerSeenTees);
    text += line;
    for (const auto& [type, missed] : {std::make_pair("elbows", result.missedElbows), std::make_pair("tees", result.missedTees)}) {
      std::snprintf(line, sizeof line, " missed_%s_unseen=%d missed_%s_pipe_not_found=%d missed_%s_not_joined=%d", type,
                    missed.unseen, type, missed.pipeNotFound, type, missed.notJoined);
      text += line;
    }
  }
  return text;
}

}  // namespace piperun
