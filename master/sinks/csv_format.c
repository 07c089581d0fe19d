/* The text of results.csv's rows in C: the accelerator of master/sinks/csv.py's ``format_rows`` (see
 * csv_native.py). A double is written as Python's repr writes it: the shortest decimal that reads back to the
 * same double (and of those the closest to it, ties to an even last digit), in fixed notation for decimal
 * exponents from -4 to 16 and in Python's exponent notation (e+16, e-05) outside; repr through the C API costs
 * ~0.6 us a value, which made a wide CSV the slowest part of a run.
 *
 * The shortest digits are found as in Raffaello Giulietti's Schubfach (2020): the double c * 2^q is scaled by
 * 10^-k, where k is chosen so that the interval of reals that round to the double is between 1 and 10 units of
 * 10^k wide; then at most one multiple of 10 lies in it (the shortest decimal, when it has fewer digits than the
 * scaled value), and otherwise the shortest decimals are the integers of the interval, of which the one nearest
 * the value is s or s + 1. The scaled value and the interval's two ends are each one product of a 126-bit
 * power of ten by a 64-bit number, rounded to odd, which keeps every comparison with an integer exact: three
 * products and a few comparisons, no loop (Ryu, used before, took digits off one at a time while its interval
 * held a shorter decimal: ~15 of the ~31 ns a value of a full-precision table). The powers of ten are computed
 * exactly by Python (csv_native.py) and handed over once with cm_csv_tables.
 *
 * Plain C without Python's API: called through ctypes, which lets other threads run meanwhile. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef unsigned __int128 u128;

#define MANTISSA_BITS 52
#define EXPONENT_BITS 11
#define K_MIN (-324)                /* the scaling exponents k of doubles (csv_native.K_MIN, K_MAX) */
#define K_MAX 292

/* g(k), by k - K_MIN: low, high 64 bits of floor(10^-k * 2^(125 - floor(log2(10^-k)))) + 1, a 126-bit number */
static uint64_t G[K_MAX - K_MIN + 1][2];
static int have_tables;

void cm_csv_tables(const uint64_t *g)
{
    memcpy(G, g, sizeof G);
    have_tables = 1;
}

/* floor(q log10(2)), floor(q log10(2) - log10(4/3)) and floor(e log2(10)) for the exponents of doubles (each
 * checked against exact integer arithmetic over its whole range: tests/master/sinks/test_csv_shortest.py) */
static inline int32_t flog10pow2(int32_t q) { return (q * 315653) >> 20; }
static inline int32_t flog10_three_quarters_pow2(int32_t q) { return (q * 315653 - 131009) >> 20; }
static inline int32_t flog2pow10(int32_t e) { return (e * 1741647) >> 19; }

/* g * cp / 2^128 rounded to odd (its floor, with the lowest bit set when its fraction is not 0), with the
 * lowest 64 bits of the product left out: g is above the exact power of ten by less than 1, so the product is above
 * the exact one by less than cp < 2^62, which stays in those bits (unless it carries), and an exact scaled value
 * (an integer, or a tie between two decimals) reads as exact. As in Schubfach, comparisons of the result with
 * even integers are then those of the exact scaled value (tests/master/sinks/test_csv_shortest.py checks them
 * against repr on millions of doubles, bench/recording/check_shortest.py on many more). */
static inline uint64_t round_to_odd(const uint64_t *g, uint64_t cp)
{
    const u128 high = (u128)g[1] * cp + (uint64_t)(((u128)g[0] * cp) >> 64);
    return (uint64_t)(high >> 64) | ((uint64_t)high != 0);
}

/* the decimal d * 10^e with the zeros at the end of d (d > 0, a multiple of 10) taken off */
static inline void without_zeros(uint64_t d, int32_t e, uint64_t *digits, int32_t *exp10)
{
    d /= 10;
    e++;
    while (d % 100000000 == 0 && d != 0) {      /* (d is never 0: no loop forever if it were) */
        d /= 100000000;
        e += 8;
    }
    if (d % 10000 == 0) {
        d /= 10000;
        e += 4;
    }
    if (d % 100 == 0) {
        d /= 100;
        e += 2;
    }
    if (d % 10 == 0) {
        d /= 10;
        e++;
    }
    *digits = d;
    *exp10 = e;
}

/* the shortest decimal of a finite nonzero double given by its fields, digits * 10^exp10; of several, the
 * nearest, and of two as near, the one with an even last digit (Python's repr) */
static void shortest(uint64_t ieee_mantissa, uint32_t ieee_exponent, uint64_t *digits, int32_t *exp10)
{
    uint64_t c;
    int32_t q;
    int irregular;          /* a power of two above the smallest normal: the interval below is half as wide */
    if (ieee_exponent == 0) {
        c = ieee_mantissa;
        q = 1 - 1075;
        irregular = 0;
    } else {
        c = (1ull << MANTISSA_BITS) | ieee_mantissa;
        q = (int32_t)ieee_exponent - 1075;
        irregular = ieee_mantissa == 0 && ieee_exponent > 1;
    }
    /* in quarter units of 2^q: the value cb and the ends of its interval, cbl and cbr, each end included when c
     * is even (a tie between two doubles reads as the even one), excluded when odd (``out``) */
    const uint64_t out = c & 1;
    const uint64_t cb = c << 2;
    const uint64_t cbr = cb + 2;
    const uint64_t cbl = irregular ? cb - 1 : cb - 2;
    /* 10^k <= the interval's width < 10^(k+1), so the scaled interval is 1 to 10 units wide */
    const int32_t k = irregular ? flog10_three_quarters_pow2(q) : flog10pow2(q);
    const int32_t h = q + flog2pow10(-k) + 3;      /* 3..6: cbr << h stays below 2^62 */
    const uint64_t *g = G[k - K_MIN];
    const uint64_t vb = round_to_odd(g, cb << h);
    const uint64_t vbl = round_to_odd(g, cbl << h);
    const uint64_t vbr = round_to_odd(g, cbr << h);
    /* the scaled value lies in [s, s + 1); a multiple of 10 in the interval (there is at most one) is the
     * shortest decimal */
    const uint64_t s = vb >> 2;
    const uint64_t sp10 = s / 10 * 10;
    const uint64_t tp10 = sp10 + 10;
    const int upin = vbl + out <= sp10 << 2;
    const int wpin = (tp10 << 2) + out <= vbr;
    if (upin != wpin) {
        without_zeros(upin ? sp10 : tp10, k, digits, exp10);
        return;
    }
    /* else every integer of the interval has as many digits: the one nearest the value, s or s + 1 */
    const uint64_t t = s + 1;
    const int uin = vbl + out <= s << 2;
    const int win = (t << 2) + out <= vbr;
    *exp10 = k;
    if (uin != win) {
        *digits = uin ? s : t;
        return;
    }
    const int64_t above_mid = (int64_t)(vb - ((s + t) << 1));     /* the value against s + 1/2, in quarters */
    *digits = above_mid < 0 || (above_mid == 0 && (s & 1) == 0) ? s : t;
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
