#include "palette.h"

#include <vtkLookupTable.h>

#include <algorithm>
#include <cmath>

namespace piperun::ui {

Rgb categoryColor(int index) {
  // Twelve well-separated hues (after ColorBrewer "Paired"/"Set1"), cycled.
  static constexpr std::array<Rgb, 12> kColors{{{31, 119, 180},
                                                {255, 127, 14},
                                                {44, 160, 44},
                                                {214, 39, 40},
                                                {148, 103, 189},
                                                {140, 86, 75},
                                                {227, 119, 194},
                                                {23, 190, 207},
                                                {188, 189, 34},
                                                {0, 90, 50},
                                                {120, 20, 120},
                                                {250, 190, 190}}};
  if (index < 0) return kNeutral;
  return kColors[static_cast<std::size_t>(index) % kColors.size()];
}

Rgb statusColor(JointStatus status) {
  switch (status) {
    case JointStatus::Accepted:
      return kAccepted;
    case JointStatus::Proposed:
      return kProposed;
    case JointStatus::Rejected:
      return kRejected;
  }
  return kNeutral;
}

vtkSmartPointer<vtkLookupTable> scalarMap(double low, double high, bool neutralAbove) {
  auto map = vtkSmartPointer<vtkLookupTable>::New();
  if (!(high > low)) high = low + 1e-6;
  map->SetTableRange(low, high);
  map->SetNumberOfTableValues(256);
  // Blue → cyan → yellow → red, brighter in the middle than a plain HSV ramp.
  for (int i = 0; i < 256; ++i) {
    const double t = i / 255.0;
    const double r = std::clamp(1.5 * t - 0.25 + 0.5 * t * t, 0.0, 1.0);
    const double g = std::clamp(1.0 - std::abs(2.0 * t - 0.95) * 1.1, 0.0, 1.0) * 0.9 + 0.1 * t;
    const double b = std::clamp(1.0 - 1.6 * t, 0.0, 1.0) * 0.85 + 0.15 * (1.0 - t);
    map->SetTableValue(i, r, g, b, 1.0);
  }
  if (neutralAbove) {
    map->SetAboveRangeColor(kNeutral[0] / 255.0, kNeutral[1] / 255.0, kNeutral[2] / 255.0, 1.0);
    map->UseAboveRangeColorOn();
  }
  map->Build();
  return map;
}

Rgb mapColor(vtkLookupTable* map, double value) {
  const unsigned char* rgba = map->MapValue(value);
  return {rgba[0], rgba[1], rgba[2]};
}

std::vector<double> roundTicks(double low, double high, int most) {
  if (!(std::isfinite(low) && std::isfinite(high)) || !(high > low) || most < 2) return {low, high};
  // The smallest round step that leaves at most `most` multiples in the range.
  const double span = high - low;
  double step = std::pow(10.0, std::floor(std::log10(span / most)));
  for (const double factor : {1.0, 2.0, 5.0, 10.0, 20.0}) {
    const double candidate = step * factor;
    if (std::floor(high / candidate) - std::ceil(low / candidate) + 1.0 <= most) {
      step = candidate;
      break;
    }
  }
  std::vector<double> ticks;
  for (double k = std::ceil(low / step); k * step <= high + 1e-9 * step; k += 1.0) {
    const double tick = k * step;
    ticks.push_back(std::fabs(tick) < 1e-9 * step ? 0.0 : tick);  // no "-0"
  }
  return ticks;
}

}  // namespace piperun::ui
