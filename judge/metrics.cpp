// compareVisibility: one pass over the pixels, counting over lit samples only (docs/ARCHITECTURE.md, "Error metric and ambiguity band").
#include "judge/metrics.h"

#include <cmath>
#include <cstdio>

#include "core/error.h"

namespace cs {

namespace {
double ratio(uint64_t num, uint64_t den) { return den ? double(num) / double(den) : 0.0; }
}  // namespace

ErrorStats compareVisibility(const GBuffer& g, const std::vector<float>& method, const std::vector<float>& reference,
                             const std::vector<uint8_t>& band) {
  CS_CHECK_EQ(g.position.size(), g.size());
  CS_CHECK_EQ(g.normal.size(), g.size());
  CS_CHECK_EQ(method.size(), g.size());
  CS_CHECK_EQ(reference.size(), g.size());
  CS_CHECK(band.empty() || band.size() == g.size(),
           "band has " << band.size() << " entries, " << g.size() << " (one per pixel) or 0 expected");
  ErrorStats s;
  double absSum = 0, absSumOutside = 0;  // doubles: 1M samples of float error sum without drift
  for (size_t i = 0; i < g.size(); ++i) {
    if (!g.isLit(i)) continue;
    const bool inBand = !band.empty() && band[i] != 0;
    const bool methodLit = method[i] >= kLitThreshold;
    const bool referenceLit = reference[i] >= kLitThreshold;
    const bool falseShadow = !methodLit && referenceLit;
    const bool falseLight = methodLit && !referenceLit;
    const double absErr = std::fabs(double(method[i]) - double(reference[i]));
    s.litSamples++;
    s.falseShadow += falseShadow;
    s.falseLight += falseLight;
    absSum += absErr;
    if (inBand) {
      s.bandSamples++;
    } else {
      s.falseShadowOutsideBand += falseShadow;
      s.falseLightOutsideBand += falseLight;
      absSumOutside += absErr;
    }
  }
  s.misclassified = s.falseShadow + s.falseLight;
  s.misclassifiedOutsideBand = s.falseShadowOutsideBand + s.falseLightOutsideBand;
  const uint64_t outside = s.litSamples - s.bandSamples;
  s.misclassifiedFraction = ratio(s.misclassified, s.litSamples);
  s.falseShadowFraction = ratio(s.falseShadow, s.litSamples);
  s.falseLightFraction = ratio(s.falseLight, s.litSamples);
  s.misclassifiedFractionOutsideBand = ratio(s.misclassifiedOutsideBand, outside);
  s.falseShadowFractionOutsideBand = ratio(s.falseShadowOutsideBand, outside);
  s.falseLightFractionOutsideBand = ratio(s.falseLightOutsideBand, outside);
  s.meanAbsError = s.litSamples ? absSum / double(s.litSamples) : 0.0;
  s.meanAbsErrorOutsideBand = outside ? absSumOutside / double(outside) : 0.0;
  s.bandFraction = ratio(s.bandSamples, s.litSamples);
  s.undecided = s.bandFraction > kUndecidedBandFraction;
  return s;
}

std::string ErrorStats::undecidedReason() const {
  if (!undecided) return "";
  char text[200];
  std::snprintf(text, sizeof text,
                "the ambiguity band covers %.3g %% of the lit samples (over %.3g %%): fp32 rounding can flip them, so "
                "no count outside the band judges this frame",
                100.0 * bandFraction, 100.0 * kUndecidedBandFraction);
  return text;
}

nlohmann::json toJson(const ErrorStats& s) {
  return {{"lit_samples", s.litSamples},
          {"band_samples", s.bandSamples},
          {"misclassified", s.misclassified},
          {"false_shadow", s.falseShadow},
          {"false_light", s.falseLight},
          {"misclassified_outside_band", s.misclassifiedOutsideBand},
          {"false_shadow_outside_band", s.falseShadowOutsideBand},
          {"false_light_outside_band", s.falseLightOutsideBand},
          {"misclassified_fraction", s.misclassifiedFraction},
          {"false_shadow_fraction", s.falseShadowFraction},
          {"false_light_fraction", s.falseLightFraction},
          {"misclassified_fraction_outside_band", s.misclassifiedFractionOutsideBand},
          {"false_shadow_fraction_outside_band", s.falseShadowFractionOutsideBand},
          {"false_light_fraction_outside_band", s.falseLightFractionOutsideBand},
          {"mean_abs_error", s.meanAbsError},
          {"mean_abs_error_outside_band", s.meanAbsErrorOutsideBand},
          {"band_fraction", s.bandFraction},
          {"undecided", s.undecided},
          {"undecided_reason", s.undecidedReason()}};
}

}  // namespace cs
