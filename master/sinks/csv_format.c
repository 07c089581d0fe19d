/* The text of results.csv's rows in C: the accelerator of master/sinks/csv.py's ``format_rows`` (see
 * csv_native.py). A double is written as Python's repr writes it: the shortest decimal that reads back to the
 * same double (and of those the closest to it, ties to an even last digit), in fixed notation for decimal
 * exponents from -4 to 16 and in Python's exponent notation (e+16, e-05) outside; repr through the C API costs
 * ~0.6 us a value, which made a wide CSV the slowest part of a run.
 *
 * The shortest digits are found as in Ulf Adams' Ryu (PLDI 2018): the value and the two ends of the interval of
 * decimals that round to it are scaled by a power of ten with 128-bit fixed-point powers of five, and digits
 * are taken off while the interval still holds a shorter decimal.  The power tables are computed exactly by
 * Python (csv_native.py) and handed over once with cm_csv_tables.
 *
 * Plain C without Python's API: called through ctypes, which lets other threads run meanwhile. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef unsigned __int128 u128;

#define MANTISSA_BITS 52
#define EXPONENT_BITS 11
#define BIAS 1023
#define POW5_INV_BITCOUNT 125
#define POW5_BITCOUNT 125
#define POW5_INV_ENTRIES 342
#define POW5_ENTRIES 326

static uint64_t POW5_INV[POW5_INV_ENTRIES][2];     /* low, high 64 bits of floor(2^(bits(5^i)-1+125) / 5^i) + 1 */
static uint64_t POW5[POW5_ENTRIES][2];             /* low, high 64 bits of 5^i scaled to exactly 125 bits */
static int have_tables;

void cm_csv_tables(const uint64_t *inv, const uint64_t *pow5)
{
    memcpy(POW5_INV, inv, sizeof POW5_INV);
    memcpy(POW5, pow5, sizeof POW5);
    have_tables = 1;
}

/* bit length of 5^e (e >= 1; 1 for e = 0) */
static inline int32_t pow5bits(int32_t e) { return (int32_t)(((uint32_t)e * 1217359) >> 19) + 1; }
/* floor(log10(2^e)) and floor(log10(5^e)) for the exponents a double can have */
static inline uint32_t log10pow2(int32_t e) { return ((uint32_t)e * 78913) >> 18; }
static inline uint32_t log10pow5(int32_t e) { return ((uint32_t)e * 732923) >> 20; }

static inline int multiple_of_pow5(uint64_t v, uint32_t p)
{
    uint32_t count = 0;
    while (v % 5 == 0) {
        v /= 5;
        count++;
    }
    return count >= p;
}

static inline int multiple_of_pow2(uint64_t v, uint32_t p) { return (v & ((1ull << p) - 1)) == 0; }

/* (m * mul) >> j for a 128-bit mul and j >= 64 */
static inline uint64_t mul_shift(uint64_t m, const uint64_t *mul, int32_t j)
{
    u128 low = (u128)m * mul[0];
    u128 high = (u128)m * mul[1];
    return (uint64_t)(((low >> 64) + high) >> (j - 64));
}

/* the shortest decimal of a finite nonzero double given by its fields: digits * 10^exp10 */
static void shortest(uint64_t ieee_mantissa, uint32_t ieee_exponent, uint64_t *digits, int32_t *exp10)
{
    int32_t e2;
    uint64_t m2;
    if (ieee_exponent == 0) {
        e2 = 1 - BIAS - MANTISSA_BITS - 2;
        m2 = ieee_mantissa;
    } else {
        e2 = (int32_t)ieee_exponent - BIAS - MANTISSA_BITS - 2;
        m2 = (1ull << MANTISSA_BITS) | ieee_mantissa;
    }
    const int accept_bounds = (m2 & 1) == 0;     /* an even mantissa: a decimal on the interval's end reads back */
    const uint64_t mv = 4 * m2;
    /* the interval below is half as wide at a power of two (but not below the smallest normal) */
    const uint32_t mm_shift = ieee_mantissa != 0 || ieee_exponent <= 1;

    uint64_t vr, vp, vm;
    int32_t e10;
    int vm_trailing_zeros = 0, vr_trailing_zeros = 0;
    if (e2 >= 0) {
        const uint32_t q = log10pow2(e2) - (e2 > 3);
        e10 = (int32_t)q;
        const int32_t k = POW5_INV_BITCOUNT + pow5bits((int32_t)q) - 1;
        const int32_t i = -e2 + (int32_t)q + k;
        vr = mul_shift(mv, POW5_INV[q], i);
        vp = mul_shift(mv + 2, POW5_INV[q], i);
        vm = mul_shift(mv - 1 - mm_shift, POW5_INV[q], i);
        if (q <= 21) {
            /* only here can the scaled values be exact (multiples of 5^q) */
            if (mv % 5 == 0)
                vr_trailing_zeros = multiple_of_pow5(mv, q);
            else if (accept_bounds)
                vm_trailing_zeros = multiple_of_pow5(mv - 1 - mm_shift, q);
            else
                vp -= multiple_of_pow5(mv + 2, q);
        }
    } else {
        const uint32_t q = log10pow5(-e2) - (-e2 > 1);
        e10 = (int32_t)q + e2;
        const int32_t i = -e2 - (int32_t)q;
        const int32_t k = pow5bits(i) - POW5_BITCOUNT;
        const int32_t j = (int32_t)q - k;
        vr = mul_shift(mv, POW5[i], j);
        vp = mul_shift(mv + 2, POW5[i], j);
        vm = mul_shift(mv - 1 - mm_shift, POW5[i], j);
        if (q <= 1) {
            /* mv has at least q trailing zero bits: the scaled values are exact */
            vr_trailing_zeros = 1;
            if (accept_bounds)
                vm_trailing_zeros = mm_shift == 1;
            else
                --vp;
        } else if (q < 63) {
            vr_trailing_zeros = multiple_of_pow2(mv, q);
        }
    }

    int32_t removed = 0;
    uint8_t last_removed = 0;
    uint64_t out;
    if (vm_trailing_zeros || vr_trailing_zeros) {
        /* the rare exact cases: the lower end may be a decimal that reads back, and a tie rounds to even */
        while (vp / 10 > vm / 10) {
            vm_trailing_zeros &= vm % 10 == 0;
            vr_trailing_zeros &= last_removed == 0;
            last_removed = (uint8_t)(vr % 10);
            vr /= 10;
            vp /= 10;
            vm /= 10;
            removed++;
        }
        if (vm_trailing_zeros) {
            while (vm % 10 == 0) {
                vr_trailing_zeros &= last_removed == 0;
                last_removed = (uint8_t)(vr % 10);
                vr /= 10;
                vp /= 10;
                vm /= 10;
                removed++;
            }
        }
        if (vr_trailing_zeros && last_removed == 5 && vr % 2 == 0)
            last_removed = 4;
        out = vr + ((vr == vm && (!accept_bounds || !vm_trailing_zeros)) || last_removed >= 5);
    } else {
        int round_up = 0;
        if (vp / 100 > vm / 100) {
            round_up = vr % 100 >= 50;
            vr /= 100;
            vp /= 100;
            vm /= 100;
            removed += 2;
        }
        while (vp / 10 > vm / 10) {
            round_up = vr % 10 >= 5;
            vr /= 10;
            vp /= 10;
            vm /= 10;
            removed++;
        }
        out = vr + (vr == vm || round_up);
    }
    *digits = out;
    *exp10 = e10 + removed;
}

static const char PAIRS[201] =
    "00010203040506070809101112131415161718192021222324252627282930313233343536373839"
    "40414243444546474849505152535455565758596061626364656667686970717273747576777879"
    "8081828384858687888990919293949596979899";

/* exactly eight digits of n < 10^8 (leading zeros included) at p, all in one 64-bit word (two halves of four
 * digits, four lanes of two, eight bytes of one): taking two digits at a time off a 17-digit value was a chain of
 * eight dependent divisions, half of a double's time */
static inline void put8(char *p, uint32_t n)
{
    const uint64_t halves = (uint64_t)(n / 10000) | ((uint64_t)(n % 10000) << 32);
    const uint64_t hundreds = ((halves * 10486) >> 20) & 0x0000007F0000007Full;      /* each half / 100 */
    const uint64_t pairs = ((halves - 100 * hundreds) << 16) | hundreds;              /* 16-bit lanes, < 100 */
    const uint64_t tens = ((pairs * 103) >> 10) & 0x000F000F000F000Full;              /* each lane / 10 */
    const uint64_t digits = (((pairs - 10 * tens) << 8) | tens) + 0x3030303030303030ull;
    memcpy(p, &digits, 8);      /* little-endian: the lowest byte is the first digit */
}

/* the decimal digits of v at the end of buf[0..24): returns where they start */
static inline char *udigits(uint64_t v, char *end)
{
    char *p = end;
    while (v >= 100000000) {
        const uint64_t q = v / 100000000;
        p -= 8;
        put8(p, (uint32_t)(v - q * 100000000));
        v = q;
    }
    uint32_t w = (uint32_t)v;
    while (w >= 100) {
        const uint32_t r = w % 100;
        w /= 100;
        p -= 2;
        memcpy(p, PAIRS + 2 * r, 2);
    }
    if (w >= 10) {
        p -= 2;
        memcpy(p, PAIRS + 2 * w, 2);
    } else {
        *--p = (char)('0' + w);
    }
    return p;
}

/* repr(x) at o; returns the end (at most 24 characters) */
static char *put_double(double x, char *o)
{
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    const int sign = (int)(bits >> 63);
    const uint64_t mantissa = bits & ((1ull << MANTISSA_BITS) - 1);
    const uint32_t exponent = (uint32_t)((bits >> MANTISSA_BITS) & ((1u << EXPONENT_BITS) - 1));
    if (exponent == (1u << EXPONENT_BITS) - 1) {
        if (mantissa) {                     /* every NaN is "nan", whatever its sign */
            memcpy(o, "nan", 3);
            return o + 3;
        }
        if (sign)
            *o++ = '-';
        memcpy(o, "inf", 3);
        return o + 3;
    }
    if (sign)
        *o++ = '-';
    if (exponent == 0 && mantissa == 0) {
        memcpy(o, "0.0", 3);
        return o + 3;
    }
    uint64_t digits;
    int32_t e10;
    shortest(mantissa, exponent, &digits, &e10);
    /* the digits end at buf + 24; the 24 bytes after them are room for the fixed-size copies below, which move
     * the digits and whatever follows them in one go (a copy of a variable length was a call each) and leave the
     * bytes past the text to be overwritten by the next cell (see ROOM) */
    char buf[48];
    char *d = udigits(digits, buf + 24);
    const int32_t n = (int32_t)(buf + 24 - d);
    const int32_t point = n + e10;          /* the value is 0.<digits> * 10^point */
    if (point <= -4 || point > 16) {
        *o = d[0];
        if (n > 1) {
            o[1] = '.';
            memcpy(o + 2, d + 1, 24);
            o += n + 1;
        } else {
            o += 1;
        }
        int32_t e = point - 1;
        *o++ = 'e';
        *o++ = e < 0 ? '-' : '+';
        if (e < 0)
            e = -e;
        if (e >= 100) {
            *o++ = (char)('0' + e / 100);
            e %= 100;
        }
        memcpy(o, PAIRS + 2 * e, 2);
        return o + 2;
    }
    if (point <= 0) {                       /* 0.<up to three zeros><digits> */
        memcpy(o, "0.000", 5);
        memcpy(o + 2 - point, d, 24);
        return o + 2 - point + n;
    }
    if (point >= n) {                       /* <digits><zeros>.0 */
        memcpy(o, d, 24);
        memset(o + n, '0', 16);
        memcpy(o + point, ".0", 2);
        return o + point + 2;
    }
    memcpy(o, d, 24);                       /* <digits before the point>.<the others> */
    memcpy(o + point + 1, d + point, 24);
    o[point] = '.';
    return o + n + 1;
}

static inline char *put_unsigned(uint64_t v, char *o)
{
    char buf[24];
    char *d = udigits(v, buf + sizeof buf);
    const size_t n = (size_t)(buf + sizeof buf - d);
    memcpy(o, d, n);
    return o + n;
}

static inline char *put_signed(int64_t v, char *o)
{
    if (v < 0) {
        *o++ = '-';
        return put_unsigned(0 - (uint64_t)v, o);
    }
    return put_unsigned((uint64_t)v, o);
}

/* the column kinds (csv_native.KINDS) */
enum { K_F64 = 1, K_F32, K_I8, K_I16, K_I32, K_I64, K_U8, K_U16, K_U32, K_U64, K_BOOL };

/* a column's last double and where its text is in the output: a value that repeats the one above it (a
 * parameter, a state at rest) is copied from the row above, not formatted again. Only where the text is: a copy of
 * each text as it was written read bytes just stored by narrower stores, which waits for them (no store
 * forwarding) at every value; the row above was written long enough ago. */
typedef struct {
    uint64_t bits;
    const char *text;           /* NULL: nothing yet */
    uint32_t len;
} Last;

/* repr(x) at o through the column's Last (a copy of 24 bytes, like put_double's; see ROOM) */
static inline char *put_double_cached(double x, char *o, Last *last)
{
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    if (last->text && last->bits == bits) {
        const char *from = last->text;
        memmove(o, from, 24);      /* one column: the row above ends just before o */
        last->text = o;
        return o + last->len;
    }
    char *end = put_double(x, o);
    last->bits = bits;
    last->text = o;
    last->len = (uint32_t)(end - o);
    return end;
}

/* Rows row0 .. row0+nrows-1 of ncols columns (cols[c]: the column's values, of kinds[c]) as CSV lines at out,
 * which holds at least nrows * (25 * ncols + 1) + ROOM bytes: a cell's text is at most 24 characters and its
 * separator, and a double's fixed-size copies write up to 42 bytes past where its cell starts (bytes that the
 * next cell overwrites; ROOM, csv_native.ROOM_BYTES = 48, covers them after the last). Returns the bytes
 * written, or -1 without tables (or memory). same_as (or NULL) names for each column an earlier one of the same
 * floating-point kind whose values in these rows are the same bits (an FMU's alias variables: 20-sim's
 * ControlledTemperature has 99 continuous Reals over 31 value references), or -1: such a column's text is copied
 * from that column's cell in the same row instead of being formatted again. */
int64_t cm_csv_rows(int64_t ncols, const int32_t *kinds, const void *const *cols, const int32_t *same_as,
                    int64_t row0, int64_t nrows, char *out)
{
    if (!have_tables)
        return -1;
    Last *last = calloc((size_t)(ncols > 0 ? ncols : 1), sizeof(Last));
    if (!last)
        return -1;
    char *o = out;
    for (int64_t r = row0; r < row0 + nrows; r++) {
        for (int64_t c = 0; c < ncols; c++) {
            const void *col = cols[c];
            if (same_as && same_as[c] >= 0) {
                const Last *from = &last[same_as[c]];
                memmove(o, from->text, 24);         /* its cell ends before o in this row: see ROOM */
                last[c] = *from;
                last[c].text = o;
                o += from->len;
                *o++ = c + 1 < ncols ? ',' : '\n';
                continue;
            }
            switch (kinds[c]) {
            case K_F64: o = put_double_cached(((const double *)col)[r], o, &last[c]); break;
            case K_F32: o = put_double_cached((double)((const float *)col)[r], o, &last[c]); break;
            case K_I8: o = put_signed(((const int8_t *)col)[r], o); break;
            case K_I16: o = put_signed(((const int16_t *)col)[r], o); break;
            case K_I32: o = put_signed(((const int32_t *)col)[r], o); break;
            case K_I64: o = put_signed(((const int64_t *)col)[r], o); break;
            case K_U8: o = put_unsigned(((const uint8_t *)col)[r], o); break;
            case K_U16: o = put_unsigned(((const uint16_t *)col)[r], o); break;
            case K_U32: o = put_unsigned(((const uint32_t *)col)[r], o); break;
            case K_U64: o = put_unsigned(((const uint64_t *)col)[r], o); break;
            case K_BOOL:
                if (((const uint8_t *)col)[r]) {
                    memcpy(o, "true", 4);
                    o += 4;
                } else {
                    memcpy(o, "false", 5);
                    o += 5;
                }
                break;
            default:
                free(last);
                return -1;
            }
            *o++ = c + 1 < ncols ? ',' : '\n';
        }
    }
    free(last);
    return (int64_t)(o - out);
}
