/* The accelerator of sitlsim/physics.py (which holds the slot layout and the reference: step_py, format_py,
 * serve_py); declared in sitlsim/accelerators.py and checked against the reference by the accelerator harness.
 *
 * sitl_step:   one SITL frame of the 6-DoF quadcopter
 * sitl_format: the JSON answer of the current state
 * sitl_serve:  the lock-step loop: receive servo frames on a UDP socket, step, answer
 *
 * Bit-identical to the reference: only + - * / sqrt and comparisons, in the Python code's order (Python
 * evaluates a + b + c as (a + b) + c, like C); compile with -ffp-contract=off (no fused multiply-add) and
 * without -ffast-math.  Numbers are printed in fixed point from integers (llrint rounds half to even like
 * Python's round), so the answers are byte-identical too.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>

enum { K, PN, PE, PD, VN, VE, VD, QW, QX, QY, QZ, RP, RQ, RR, FX, FY, FZ, M1, M2, M3, M4, PWM1, PWM2, PWM3,
       PWM4, WN, WE, WD, POWER, ENERGY, GROUND, LAST, HAS_LAST, ANSWERED, RESETS, STALE, BAD,
       SITL_RATE, NSTATE };
enum { DT, G, MASS, IXX, IYY, IZZ, KF, WMAX, KM, AUP, ADN, RDRAG, BDRAG, EXPO, SPIN_MIN, SPIN_RANGE, PWM_MIN,
       PWM_RANGE, PIND, PPROF, EFF_INV, AVIONICS, RATE, Q0W, Q0Z, MX1, NPARAM = MX1 + 12 };
enum { IO_NFRAMES, IO_TIMEOUT, IO_NO_TIME_SYNC, IO_STATUS, IO_WAITED, IO_T_WAIT, IO_T_PHYS, IO_T_IO, IO_ERRNO,
       NIO };
enum { ST_OK = 0, ST_SILENT = 1, ST_SOCKET_ERROR = 2, ST_INTERRUPTED = 3 };
#define MAGIC_16 18458
#define MAGIC_32 29569
#define SIZE_16 40
#define SIZE_32 72

void sitl_reset(double *s, const double *p)
{
    for (int i = PN; i < WN; i++)
        s[i] = 0.0;
    s[K] = 0.0;
    s[QW] = p[Q0W];
    s[QZ] = p[Q0Z];
    s[FZ] = -p[G];
    s[GROUND] = 1.0;
    s[POWER] = p[AVIONICS];
}

void sitl_step(double *s, const double *p)
{
    const double dt = p[DT], g = p[G], mass = p[MASS];
    const double kf = p[KF], wmax = p[WMAX], km = p[KM], aup = p[AUP], adn = p[ADN];
    const double e = p[EXPO], smin = p[SPIN_MIN], srange = p[SPIN_RANGE], pmin = p[PWM_MIN], prange = p[PWM_RANGE];
    const double pind = p[PIND], pprof = p[PPROF];
    double tsum = 0.0, wsum = 0.0, tx = 0.0, ty = 0.0, tz = 0.0, pw = 0.0;
    for (int i = 0; i < 4; i++) {
        double x = ((s[PWM1 + i] - pmin) / prange - smin) / srange, wc, w, t;
        const int j = MX1 + 3 * i;
        if (x < 0.0)
            x = 0.0;
        else if (x > 1.0)
            x = 1.0;
        wc = wmax * sqrt((1.0 - e) * x + e * x * x);
        w = s[M1 + i];
        if (wc > w)
            w = w + aup * (wc - w);
        else
            w = w + adn * (wc - w);
        s[M1 + i] = w;
        t = kf * w * w;
        tsum += t;
        wsum += w;
        tx -= p[j + 1] * t;
        ty += p[j] * t;
        tz += p[j + 2] * km * t;
        pw += pind * t * sqrt(t) + pprof * w * w * w;
    }
    const double qw = s[QW], qx = s[QX], qy = s[QY], qz = s[QZ];
    const double r00 = 1.0 - 2.0 * (qy * qy + qz * qz);
    const double r01 = 2.0 * (qx * qy - qw * qz);
    const double r02 = 2.0 * (qx * qz + qw * qy);
    const double r10 = 2.0 * (qx * qy + qw * qz);
    const double r11 = 1.0 - 2.0 * (qx * qx + qz * qz);
    const double r12 = 2.0 * (qy * qz - qw * qx);
    const double r20 = 2.0 * (qx * qz - qw * qy);
    const double r21 = 2.0 * (qy * qz + qw * qx);
    const double r22 = 1.0 - 2.0 * (qx * qx + qy * qy);
    const double an = s[VN] - s[WN], ae = s[VE] - s[WE], ad = s[VD] - s[WD];
    const double bx = r00 * an + r10 * ae + r20 * ad;
    const double by = r01 * an + r11 * ae + r21 * ad;
    const double bz = r02 * an + r12 * ae + r22 * ad;
    const double va = sqrt(an * an + ae * ae + ad * ad);
    const double bd = p[BDRAG] * va;
    const double rd = p[RDRAG] * wsum;
    double fx = (-rd * bx - bd * bx) / mass;
    double fy = (-rd * by - bd * by) / mass;
    double fz = (-tsum - bd * bz) / mass;
    const double ixx = p[IXX], iyy = p[IYY], izz = p[IZZ];
    const double rp = s[RP], rq = s[RQ], rr = s[RR];
    double rp2 = rp + (tx - (rq * izz * rr - rr * iyy * rq)) / ixx * dt;
    double rq2 = rq + (ty - (rr * ixx * rp - rp * izz * rr)) / iyy * dt;
    double rr2 = rr + (tz - (rp * iyy * rq - rq * ixx * rp)) / izz * dt;
    const double h = 0.5 * dt;
    double nw = qw + (-qx * rp2 - qy * rq2 - qz * rr2) * h;
    double nx = qx + (qw * rp2 + qy * rr2 - qz * rq2) * h;
    double ny = qy + (qw * rq2 - qx * rr2 + qz * rp2) * h;
    double nz = qz + (qw * rr2 + qx * rq2 - qy * rp2) * h;
    double n = sqrt(nw * nw + nx * nx + ny * ny + nz * nz);
    double vn = s[VN] + (r00 * fx + r01 * fy + r02 * fz) * dt;
    double ve = s[VE] + (r10 * fx + r11 * fy + r12 * fz) * dt;
    double vd = s[VD] + (r20 * fx + r21 * fy + r22 * fz + g) * dt;
    const double pn = s[PN] + vn * dt, pe = s[PE] + ve * dt;
    double pd = s[PD] + vd * dt;
    double climb = -vd * mass * g;
    if (climb < 0.0)
        climb = 0.0;
    const double power = (pw + bd * va * va + climb) * p[EFF_INV] + p[AVIONICS];
    if (pd >= 0.0) {
        pd = vn = ve = vd = rp2 = rq2 = rr2 = 0.0;
        nw = qw;
        nz = qz;
        n = sqrt(nw * nw + nz * nz);
        nx = ny = 0.0;
        fx = fy = 0.0;
        fz = -g;
        s[GROUND] = 1.0;
    } else {
        s[GROUND] = 0.0;
    }
    s[PN] = pn; s[PE] = pe; s[PD] = pd; s[VN] = vn; s[VE] = ve; s[VD] = vd;
    s[QW] = nw / n; s[QX] = nx / n; s[QY] = ny / n; s[QZ] = nz / n;
    s[RP] = rp2; s[RQ] = rq2; s[RR] = rr2; s[FX] = fx; s[FY] = fy; s[FZ] = fz;
    s[POWER] = power;
    s[ENERGY] += power * dt;
    s[K] += 1.0;
}

static int64_t timestamp_ns(double k, double rate)
{
    const int64_t ki = (int64_t)k, r = (int64_t)rate;
    return (ki * 1000000) / r * 1000 + ki;
}

#define LIMIT 9000000000000000000LL

/* |n| as "a.bbbbbbbbb" (9 decimals) at b, with a leading '-' if neg; returns the end */
static char *put_fixed(char *b, int neg, uint64_t n)
{
    char tmp[24];
    int i = 0;
    uint64_t a = n / 1000000000ULL, f = n % 1000000000ULL;
    if (neg)
        *b++ = '-';
    do {
        tmp[i++] = (char)('0' + a % 10);
        a /= 10;
    } while (a);
    while (i)
        *b++ = tmp[--i];
    *b++ = '.';
    for (int j = 8; j >= 0; j--) {
        b[j] = (char)('0' + f % 10);
        f /= 10;
    }
    return b + 9;
}

/* frames.fixed: round-half-even(v * 1e9) (llrint, default rounding mode = Python's round), clamped */
static char *put_value(char *b, double v)
{
    long long n;
    double x = v * 1e9;
    if (v != v)
        n = 0;
    else if (x >= 9.0e18)
        n = LIMIT;
    else if (x <= -9.0e18)
        n = -LIMIT;
    else
        n = llrint(x);
    if (n > LIMIT)
        n = LIMIT;
    if (n < -LIMIT)
        n = -LIMIT;
    return n < 0 ? put_fixed(b, 1, (uint64_t)(-n)) : put_fixed(b, 0, (uint64_t)n);
}

static char *put_str(char *b, const char *s)
{
    while (*s)
        *b++ = *s++;
    return b;
}

static char *put_vec(char *b, const double *v, int n)
{
    *b++ = '[';
    for (int i = 0; i < n; i++) {
        if (i)
            *b++ = ',';
        b = put_value(b, v[i]);
    }
    *b++ = ']';
    return b;
}

/* The answer into buf (at least 512 bytes: 17 numbers of at most 30 characters and 130 of keys). */
int sitl_format(const double *s, const double *p, int no_time_sync, char *buf, int cap)
{
    char *b = buf;
    if (cap < 1024)
        return 0;
    b = put_str(b, "\n{\"timestamp\":");
    b = put_fixed(b, 0, (uint64_t)timestamp_ns(s[K], p[RATE]));
    b = put_str(b, ",\"imu\":{\"gyro\":");
    b = put_vec(b, s + RP, 3);
    b = put_str(b, ",\"accel_body\":");
    b = put_vec(b, s + FX, 3);
    b = put_str(b, "},\"position\":");
    b = put_vec(b, s + PN, 3);
    b = put_str(b, ",\"velocity\":");
    b = put_vec(b, s + VN, 3);
    b = put_str(b, ",\"quaternion\":");
    b = put_vec(b, s + QW, 4);
    if (no_time_sync)
        b = put_str(b, ",\"no_time_sync\":1");
    b = put_str(b, "}\n");
    return (int)(b - buf);
}

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static uint16_t rd16(const unsigned char *b) { return (uint16_t)(b[0] | (b[1] << 8)); }
static uint32_t rd32(const unsigned char *b)
{
    return (uint32_t)b[0] | ((uint32_t)b[1] << 8) | ((uint32_t)b[2] << 16) | ((uint32_t)b[3] << 24);
}

/* Answer io[IO_NFRAMES] new servo frames; the same loop as physics.serve_py.  Returns the frames answered;
 * io[IO_STATUS] says why it stopped.  One blocking recvfrom per frame (SO_RCVTIMEO ticks of at most 50 ms
 * bound each wait, so the timeouts are checked at least that often) and one sendto: two system calls.
 * A frame SITL re-sent (same frame_count as the last answered) is counted and never answered: SITL re-sends
 * only while our answer has not reached it yet, and on loopback an answer is never lost, so a second answer
 * would be read as the answer to SITL's next frame and put the firmware one frame ahead of the physics for
 * the rest of the run (docs/sitl_physics.md, "Re-sent frames"). */
int sitl_serve(int fd, double *s, const double *p, double *io)
{
    const int nframes = (int)io[IO_NFRAMES], nts = io[IO_NO_TIME_SYNC] != 0.0;
    const double timeout = io[IO_TIMEOUT];
    double tick = 0.05;
    unsigned char pkt[256];
    char msg[1024];
    struct timeval tv;
    int answered = 0, status = ST_OK, msglen;
    double last_new = now_s(), t_wait = 0.0, t_phys = 0.0, t_io = 0.0;

    if (timeout < tick)
        tick = timeout;
    if (tick < 0.001)
        tick = 0.001;
    tv.tv_sec = (time_t)tick;
    tv.tv_usec = (suseconds_t)((tick - (double)tv.tv_sec) * 1e6);
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    io[IO_ERRNO] = 0.0;
    while (answered < nframes) {
        struct sockaddr_in src;
        socklen_t srclen = sizeof src;
        ssize_t len;
        uint32_t count;
        double t1 = now_s(), t2, t3;
        len = recvfrom(fd, pkt, sizeof pkt, 0, (struct sockaddr *)&src, &srclen);
        t2 = now_s();
        t_wait += t2 - t1;
        if (len < 0) {
            if (errno == EINTR) {          /* a signal (Ctrl-C): let Python run its handler, then resume */
                status = ST_INTERRUPTED;
                break;
            }
            if (errno != EAGAIN && errno != EWOULDBLOCK && errno != ECONNREFUSED) {
                status = ST_SOCKET_ERROR;
                io[IO_ERRNO] = errno;
                break;
            }
            if (t2 - last_new >= timeout) {
                status = ST_SILENT;
                io[IO_WAITED] = t2 - last_new;
                break;
            }
            continue;
        }
        if (len < 8) {
            s[BAD] += 1.0;
            continue;
        }
        {
            const uint16_t magic = rd16(pkt);
            if (!((magic == MAGIC_16 && len == SIZE_16) || (magic == MAGIC_32 && len == SIZE_32))) {
                s[BAD] += 1.0;
                continue;
            }
        }
        count = rd32(pkt + 4);
        if (s[HAS_LAST] != 0.0 && (double)count == s[LAST]) {
            s[STALE] += 1.0;
            continue;
        }
        if (s[HAS_LAST] != 0.0 && (double)count < s[LAST]) {
            sitl_reset(s, p);
            s[RESETS] += 1.0;
        }
        s[PWM1] = rd16(pkt + 8);
        s[PWM2] = rd16(pkt + 10);
        s[PWM3] = rd16(pkt + 12);
        s[PWM4] = rd16(pkt + 14);
        s[SITL_RATE] = rd16(pkt + 2);
        sitl_step(s, p);
        msglen = sitl_format(s, p, nts, msg, sizeof msg);
        t3 = now_s();
        t_phys += t3 - t2;
        sendto(fd, msg, (size_t)msglen, 0, (struct sockaddr *)&src, srclen);
        last_new = now_s();
        t_io += last_new - t3;
        s[LAST] = (double)count;
        s[HAS_LAST] = 1.0;
        s[ANSWERED] += 1.0;
        answered++;
    }
    io[IO_STATUS] = status;
    if (status == ST_OK)
        io[IO_WAITED] = 0.0;
    io[IO_T_WAIT] = t_wait;
    io[IO_T_PHYS] = t_phys;
    io[IO_T_IO] = t_io;
    return answered;
}
