// What every scene loader does before a parser sees a byte: read a file that must be a regular file of
// bounded size, refuse inputs whose claims (element counts, nesting, number lengths) a parser would act
// on before it could notice they are false, check cameras read from files, and quote input in messages
// safely (one line, clipped, no control bytes).
#pragma once
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>

#include "core/error.h"
#include "core/scene.h"

namespace cs {

// At most this many characters of input are quoted in a message; a message is clipped to kMaxMessage.
inline constexpr size_t kMaxQuote = 60;
inline constexpr size_t kMaxMessage = 300;

// `text` between single quotes, control bytes (NUL, newlines) and non-ASCII bytes shown as '?', clipped to
// `max` characters with "..." and the full length when longer.
std::string quoteInput(std::string_view text, size_t max = kMaxQuote);
// The same without the quotes (for JSON values, which carry their own).
std::string clipInput(std::string_view text, size_t max = kMaxQuote);
// `text` on one line (line breaks become "; "), control bytes as '?', at most `max` characters.
std::string oneLineClipped(std::string_view text, size_t max = kMaxMessage);

// The same error on one line, its parts clipped so that the message stays within about kMaxMessage.
Error clippedError(const Error& e);

// The whole file after checkSceneInput: "cannot read" when it exists but reading fails, and refused when
// it reads more or fewer bytes than its size says (a /proc file, or one changing under us), or more than
// `maxBytes`. `from` names what referred to it, as for checkSceneInput.
std::string readSceneBytes(const std::string& path, const std::string& from = {},
                           uint64_t maxBytes = kMaxSceneFileBytes);

// Markup (XML) nests at most this many elements deep: assimp's XML readers recurse once a level.
inline constexpr size_t kMaxXmlDepth = 256;
// A number in a text format has at most this many characters of digits (a double needs 17; fully written
// denormals about 330): longer ones were read as a wrong value.
inline constexpr size_t kMaxNumberDigits = 400;
// How deep the elements of `text` nest (comments, CDATA, processing instructions and declarations
// skipped); stops counting past `limit`.
size_t xmlDepth(std::string_view text, size_t limit);
// The checks made on a file's bytes before assimp parses it (by content, and by extension where the
// format has no signature): counts a header claims against the bytes that could hold them (PLY, OFF,
// binary STL, Collada count attributes), XML nesting, overlong numbers, and OFF face indices, which assimp
// clamps. cs::Error naming the file otherwise.
void checkAssimpInput(const std::string& path, std::string_view bytes);

// A camera's far/near ratio may be at most this: beyond it the float depth buffer (D32, 24-bit mantissa)
// no longer separates surfaces near the far plane and the rasterised G-buffer drops samples.
inline constexpr double kMaxDepthRatio = 1e7;
// A camera read from `file` (`what` names it, e.g. "camera 'cam'"): eye and target finite and distinct,
// yfov in (0, pi), 0 < znear < zfar, all in float, and far / znear <= kMaxDepthRatio where far is zfar or,
// when nearer, `reach` (the distance to the scene's farthest point: depth precision matters only where
// there is geometry). cs::Error otherwise.
void checkFileCamera(const Camera& c, const std::string& file, const std::string& what,
                     double reach = std::numeric_limits<double>::infinity());

}  // namespace cs
