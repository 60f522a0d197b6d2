#include "core/FloatingPoint.h"

#if defined(__SSE__) || defined(__x86_64__)
#include <xmmintrin.h>
#define MPM_HAS_MXCSR 1
#endif

namespace mpm {

namespace {
#ifdef MPM_HAS_MXCSR
/// MXCSR's flush-to-zero (bit 15) and denormals-are-zero (bit 6).
constexpr unsigned kFlushBits = 0x8040u;
unsigned readMode() { return _mm_getcsr(); }
void writeMode(unsigned mode) { _mm_setcsr(mode); }
#else
constexpr unsigned kFlushBits = 0u;
unsigned readMode() { return 0u; }
void writeMode(unsigned) {}
#endif

}  // namespace

DenormalsFlushed::DenormalsFlushed() : saved_(readMode()) { writeMode(saved_ | kFlushBits); }
DenormalsFlushed::~DenormalsFlushed() { writeMode(saved_); }

bool denormalsFlushed() { return (readMode() & kFlushBits) == kFlushBits; }

}  // namespace mpm
