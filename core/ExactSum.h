#pragma once
// An exact, order-independent sum of doubles: a long fixed-point accumulator spanning every double's range
// (Kulisch's long accumulator; Neal 2015, "Fast exact summation using small and large superaccumulators").
// Each term is added exactly as integer digits, so the total is the same bits whatever the order of the
// terms, the split of the work over threads, or the number of processes that each sum a part. That is what
// lets the diagnostics and the energy bookkeeping of a run be identical on 1 or N threads and ranks.
// Ours rather than a library's: none in Debian offers it, and it is a few dozen lines.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

namespace mpm {

class ExactSum {
public:
    /// 32-bit digits in 64-bit limbs: a limb takes 2^30 additions of a digit before its carries must move up.
    static constexpr int kDigitBits = 32;
    /// A double's last mantissa bit weighs 2^(p - 1074) for p in [0, 2045]; a term's 53 bits start at digit
    /// p / 32 and, shifted by p % 32, span three digits.
    static constexpr int kLimbs = (2046 + 53 + 31) / kDigitBits + 2;
    static constexpr int kExponentBias = 1074;

    void add(double x) {
        uint64_t bits;
        std::memcpy(&bits, &x, sizeof bits);
        const int biased = int(bits >> 52) & 0x7ff;
        if (biased == 0x7ff) {  // inf or NaN: not summable digits, kept apart
            special_ += x;
            return;
        }
        uint64_t mantissa = bits & ((uint64_t(1) << 52) - 1);
        if (biased != 0) mantissa |= uint64_t(1) << 52;
        if (mantissa == 0) return;
        const int p = biased == 0 ? 0 : biased - 1;
        const unsigned __int128 shifted = static_cast<unsigned __int128>(mantissa) << (p % kDigitBits);
        const int i = p / kDigitBits;
        const int64_t sign = (bits >> 63) ? -1 : 1;
        limb_[i] += sign * int64_t(uint32_t(shifted));
        limb_[i + 1] += sign * int64_t(uint32_t(shifted >> 32));
        limb_[i + 2] += sign * int64_t(uint32_t(shifted >> 64));
        if (++pending_ >= kMaxPending) normalise();
    }
    ExactSum& operator+=(double x) {
        add(x);
        return *this;
    }
    ExactSum& operator+=(const ExactSum& o) {
        ExactSum b = o;
        b.normalise();
        normalise();
        for (int i = 0; i < kLimbs; ++i) limb_[i] += b.limb_[i];
        special_ += b.special_;
        pending_ = 2;
        return *this;
    }

    /// Moves every limb's carry into the next one: digits in [0, 2^32), the sign in the top limb. The result
    /// is unique for a given total, so any two accumulators of the same terms end with the same limbs.
    void normalise() {
        for (int i = 0; i + 1 < kLimbs; ++i) {
            const int64_t carry = limb_[i] >> kDigitBits;  // arithmetic shift: floor division
            limb_[i] -= carry * (int64_t(1) << kDigitBits);
            limb_[i + 1] += carry;
        }
        pending_ = 0;
    }

    /// The total rounded to a double (within one unit in the last place; the same bits for the same total).
    double value() const {
        if (special_ != 0.0 || std::isnan(special_)) return special_;
        ExactSum a = *this;
        a.normalise();
        const bool negative = a.limb_[kLimbs - 1] < 0;
        if (negative) {  // magnitude by two's complement over the digits
            int64_t borrow = 0;
            for (int i = 0; i < kLimbs; ++i) {
                int64_t d = -a.limb_[i] - borrow;
                borrow = 0;
                if (i + 1 < kLimbs && d < 0) d += int64_t(1) << kDigitBits, borrow = 1;
                a.limb_[i] = d;
            }
        }
        int top = kLimbs - 1;
        while (top >= 0 && a.limb_[top] == 0) --top;
        if (top < 0) return 0.0;
        // The top three digits, 65 to 96 significant bits, rounded once to a double.
        unsigned __int128 head = 0;
        for (int k = 0; k < 3; ++k) head = (head << kDigitBits) | uint64_t(top - k >= 0 ? a.limb_[top - k] : 0);
        const double m = double(head);
        const double r = std::ldexp(m, (top - 2) * kDigitBits - kExponentBias);
        return negative ? -r : r;
    }
    /// The limbs, for a sum over processes: normalised, they add as integers (see Comm).
    int64_t* limbs() { return limb_; }
    double& special() { return special_; }

private:
    static constexpr int kMaxPending = 1 << 30;
    int64_t limb_[kLimbs] = {};
    double special_ = 0.0;  ///< the sum of infinite and NaN terms
    int pending_ = 0;
};

}  // namespace mpm
