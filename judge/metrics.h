// The error metric (docs/ARCHITECTURE.md, "Error metric and ambiguity band"): a method's visibility against the reference's, over the
// samples that face the light, thresholded at 0.5, split into false shadow / false light, with and
// without the ambiguity band, plus mean absolute visibility error.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "raster/gbuffer.h"

namespace cs {

// Visibility at or above this is "lit" when a value in [0,1] is turned into a classification.
inline constexpr float kLitThreshold = 0.5f;

// A frame whose ambiguity band holds more than this fraction of its lit samples is undecided: the
// reference cannot tell a right mask from a wrong one there, so no count outside the band is a verdict.
inline constexpr double kUndecidedBandFraction = 0.01;

struct ErrorStats {
  uint64_t litSamples = 0;                // samples counted: GBuffer::isLit
  uint64_t bandSamples = 0;               // lit samples in the ambiguity band
  uint64_t misclassified = 0;             // (method >= 0.5) != (reference >= 0.5)
  uint64_t falseShadow = 0;               // method < 0.5 where reference >= 0.5
  uint64_t falseLight = 0;                // method >= 0.5 where reference < 0.5
  uint64_t misclassifiedOutsideBand = 0;  // the same, over lit samples not in the band
  uint64_t falseShadowOutsideBand = 0;
  uint64_t falseLightOutsideBand = 0;
  // Fractions of litSamples (outside-band ones: of litSamples - bandSamples); 0 when the count is 0.
  double misclassifiedFraction = 0;
  double falseShadowFraction = 0;
  double falseLightFraction = 0;
  double misclassifiedFractionOutsideBand = 0;
  double falseShadowFractionOutsideBand = 0;
  double falseLightFractionOutsideBand = 0;
  double meanAbsError = 0;                // mean |method - reference| over lit samples
  double meanAbsErrorOutsideBand = 0;     // the same over lit samples not in the band
  double bandFraction = 0;                // bandSamples / litSamples; 0 when no sample is lit
  bool undecided = false;                 // bandFraction > kUndecidedBandFraction

  // Why the frame is undecided, for a result line or a report; "" when it is decided.
  std::string undecidedReason() const;
};

// method, reference: one value per pixel of `gbuffer`. band: one byte per pixel (nonzero = in band), or
// empty for "no band". Throws cs::Error on mismatched sizes.
ErrorStats compareVisibility(const GBuffer& gbuffer, const std::vector<float>& method,
                             const std::vector<float>& reference, const std::vector<uint8_t>& band);

// Field names in snake_case, the same names results.csv uses after "error.".
nlohmann::json toJson(const ErrorStats& stats);

}  // namespace cs
