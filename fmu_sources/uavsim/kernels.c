/* The accelerator of the UAV models' hot loops: uavsim/kernels.py holds the reference (the Python loops) and the
 * layout; declared in uavsim/accelerators.py and checked against the reference by the accelerator harness.
 *
 * uav_fly:           the flying sub-steps of uavsim.dynamics.Dynamics (takeoff, fly, land phases): kernels.fly_py
 * uav_battery:       the coulomb-counting sub-steps of uavsim.battery.Battery.step: kernels.battery_py
 * uav_battery_step:  the battery's whole step: kernels.battery_step_py
 *
 * They must give bit-identical results to the references, so they use only the operations whose IEEE
 * results do not depend on the language: + - * / sqrt, comparisons and copysign, in the same order as the
 * Python code (which evaluates a + b + c as (a + b) + c, like C).  Compile without contraction of a*b+c into
 * fused multiply-adds (-ffp-contract=off) and without -ffast-math; uavsim/native.py's FLAGS do.
 */
#include <math.h>

/* state slots (kernels.py: S_*) */
enum { PX, PY, PZ, VX, VY, VTX, VTY, VTZ, IX, IY, AX, AY, HX, HY, HOLDZ, PHASE, MODE, LANDED, I, N, H, CMD,
       SPX, SPY, SPZ, WX, WY, NSTATE };
/* parameter slots (kernels.py: P_*) */
enum { SPEED, ACCEL, POS_P, VEL_P, VEL_I, ACCEL_Z, POS_Z_P, SPEED_UP, SPEED_DN, LAND_SPEED, LAND_ALT_LOW,
       TAKEOFF_ALT, DRAG_K, AMAX, PUSH, NPARAM };
enum { TAKEOFF = 1, FLY = 2, LAND = 3 };
enum { CMD_GOTO = 2, CMD_LAND = 3 };

static double dmin(double a, double b) { return b < a ? b : a; }   /* Python min(a, b) */
static double dmax(double a, double b) { return b > a ? b : a; }   /* Python max(a, b) */

int uav_fly(double *s, const double *p)
{
    const double speed = p[SPEED], accel = p[ACCEL], pos_p = p[POS_P], vel_p = p[VEL_P], vel_i = p[VEL_I];
    const double lin = accel / (pos_p * pos_p);
    /* Two square roots on the sub-step's critical path are skipped where their rounded value cannot change the
     * result (a correctly rounded sqrt is monotonic and speed, lim are doubles): x >= cruise_sq >= speed^2 gives
     * sqrt(x) >= speed, so min(speed, sqrt(x)) is speed; q <= lim_sq_below <= lim^2 gives sqrt(q) <= lim, so the
     * change is not limited.  The margins 2^-40 exceed the rounding of the products by far. */
    const double cruise_sq = speed * speed * (1.0 + 0x1p-40);
    const double accel_z = p[ACCEL_Z], pos_z_p = p[POS_Z_P], speed_up = p[SPEED_UP], speed_dn = p[SPEED_DN];
    const double lin_z = accel_z / (pos_z_p * pos_z_p);
    const double land_speed = p[LAND_SPEED], land_alt_low = p[LAND_ALT_LOW], takeoff_alt = p[TAKEOFF_ALT];
    const double k = p[DRAG_K], amax = p[AMAX];
    const int push = p[PUSH] != 0.0;
    const int n = (int)s[N], cmd = (int)s[CMD], goto_ = cmd == CMD_GOTO;
    const double h = s[H];
    const double lim = accel * h, limz = accel_z * h;
    const double lim_sq_below = lim > 0.0 ? lim * lim * (1.0 - 0x1p-40) : -1.0;
    const double wx = s[WX], wy = s[WY], spx = s[SPX], spy = s[SPY], spz = s[SPZ];
    /* drag acts on the velocity relative to the air: the wind's (drag) or the vehicle's own (push) */
    const double dwx = push ? 0.0 : wx, dwy = push ? 0.0 : wy;
    double px = s[PX], py = s[PY], pz = s[PZ], vx = s[VX], vy = s[VY];
    double vtx = s[VTX], vty = s[VTY], vtz = s[VTZ], ix = s[IX], iy = s[IY];
    double hx = s[HX], hy = s[HY], hold_z = s[HOLDZ], ax = 0.0, ay = 0.0;
    int phase = (int)s[PHASE], mode = (int)s[MODE], landed = 0, i = (int)s[I];

    while (i < n) {
        double q, gx, gy, gz, ex, ey, d, vmag, vdx, vdy, dvx, dvy, dvm, sx, evx, evy, am, vax, vay, va, ez, vzd;
        i += 1;
        if (cmd == CMD_LAND && (phase == TAKEOFF || phase == FLY)) {
            phase = LAND;
            hx = px; hy = py;
        }
        if (phase == FLY) {
            if (goto_) {
                mode = 1;
            } else if (mode == 1) {
                mode = 0;
                hx = px; hy = py;
                hold_z = pz;
            }
        }
        if (phase == FLY && mode == 1) {
            gx = spx; gy = spy; gz = spz;
        } else {
            gx = hx; gy = hy;
            if (phase == TAKEOFF) gz = takeoff_alt;
            else if (phase == FLY) gz = hold_z;
            else gz = pz;
        }
        /* horizontal controller */
        ex = gx - px; ey = gy - py;
        d = sqrt(ex * ex + ey * ey);
        if (d <= 0.0) vmag = 0.0;
        else if (d <= lin) vmag = pos_p * d;
        else {
            const double x = 2.0 * accel * (d - 0.5 * lin);
            vmag = x >= cruise_sq ? speed : sqrt(x);        /* far away: the speed limit, no root needed */
        }
        vmag = dmin(speed, vmag);
        if (d > 1e-9) {
            vdx = vmag * ex / d; vdy = vmag * ey / d;
        } else {
            vdx = 0.0; vdy = 0.0;
        }
        dvx = vdx - vtx; dvy = vdy - vty;
        q = dvx * dvx + dvy * dvy;
        if (q > lim_sq_below && (dvm = sqrt(q)) > lim) {
            dvx = dvx * lim / dvm; dvy = dvy * lim / dvm;
        }
        vtx += dvx;
        vty += dvy;
        sx = sqrt(vx * vx + vy * vy);
        evx = vtx - vx; evy = vty - vy;
        ax = dvx / h + vel_p * evx + vel_i * ix + k * sx * vx;
        ay = dvy / h + vel_p * evy + vel_i * iy + k * sx * vy;
        am = sqrt(ax * ax + ay * ay);
        if (am > amax) {
            ax = ax * amax / am; ay = ay * amax / am;
        } else {
            ix += evx * h;
            iy += evy * h;
        }
        vax = vx - dwx; vay = vy - dwy;
        va = sqrt(vax * vax + vay * vay);
        vx += (ax - k * va * vax) * h;
        vy += (ay - k * va * vay) * h;
        /* vertical */
        ez = gz - pz;
        if (phase == LAND) {
            vzd = -(pz <= land_alt_low ? land_speed : speed_dn);
        } else {
            double aez = fabs(ez);
            if (aez <= 0.0) vzd = 0.0;
            else if (aez <= lin_z) vzd = pos_z_p * aez;
            else vzd = sqrt(2.0 * accel_z * (aez - 0.5 * lin_z));
            vzd = copysign(vzd, ez);
            vzd = dmax(-speed_dn, dmin(speed_up, vzd));
        }
        vtz += dmax(-limz, dmin(limz, vzd - vtz));
        if (push) {        /* carried by the air mass */
            px += (vx + wx) * h;
            py += (vy + wy) * h;
        } else {
            px += vx * h;
            py += vy * h;
        }
        pz += vtz * h;
        /* transitions */
        if (phase == TAKEOFF && pz >= takeoff_alt - 0.2) {
            phase = FLY;
            mode = 0;
            hold_z = takeoff_alt;
        }
        if (phase == LAND && pz <= 0.0) {
            landed = 1;
            break;
        }
    }
    s[PX] = px; s[PY] = py; s[PZ] = pz; s[VX] = vx; s[VY] = vy;
    s[VTX] = vtx; s[VTY] = vty; s[VTZ] = vtz; s[IX] = ix; s[IY] = iy; s[AX] = ax; s[AY] = ay;
    s[HX] = hx; s[HY] = hy; s[HOLDZ] = hold_z; s[PHASE] = phase; s[MODE] = mode; s[LANDED] = landed;
    s[I] = i;
    return i;
}

/* battery state slots (kernels.py: B_*) */
enum { BQ, BE, BCUR, BOVER, BVOLT, BPOW, BN, BH, BDEMAND, BSTATE };
/* battery parameter slots: cells, resistance, capacity (C), table length m, then m soc and m ocv values */
enum { BCELLS, BRES, BCAP, BM, BTABLE };

int uav_battery(double *s, const double *p)
{
    const double cells = p[BCELLS], r = p[BRES], cap = p[BCAP];
    const int m = (int)p[BM];
    const double *xs = p + BTABLE, *ys = p + BTABLE + m;
    const double x0 = xs[0], x1 = xs[m - 1], y0 = ys[0], y1 = ys[m - 1];
    const int n = (int)s[BN];
    const double h = s[BH], demand = s[BDEMAND];
    double q = s[BQ], e = s[BE], cur = 0.0, volt = 0.0, pw = 0.0;
    int over = 0;
    for (int i = 0; i < n + 1; i++) {
        double soc = dmax(0.0, 1.0 - q / cap), ocv, emf, disc;
        if (soc <= x0) {
            ocv = y0;
        } else if (soc >= x1) {
            ocv = y1;
        } else {
            int lo = 0, hi = m;             /* bisect_right(xs, soc) */
            while (lo < hi) {
                int mid = (lo + hi) / 2;
                if (soc < xs[mid]) hi = mid; else lo = mid + 1;
            }
            int j = lo - 1;
            ocv = ys[j] + (soc - xs[j]) / (xs[j + 1] - xs[j]) * (ys[j + 1] - ys[j]);
        }
        emf = cells * ocv;
        if (r <= 0.0) {
            cur = demand / emf; over = 0;
        } else {
            disc = emf * emf - 4.0 * r * demand;
            if (disc < 0.0) {
                cur = emf / (2.0 * r); over = 1;
            } else {
                cur = (emf - sqrt(disc)) / (2.0 * r); over = 0;
            }
        }
        volt = emf - cur * r;
        pw = volt * cur;
        if (i < n) {
            q += cur * h;
            e += pw * h;
        }
    }
    s[BQ] = q; s[BE] = e; s[BCUR] = cur; s[BOVER] = over; s[BVOLT] = volt; s[BPOW] = pw;
    return n;
}

/* uav_battery_step: one whole Battery.step with the inputs held -- the Zeng power demand (uavsim.battery's
 * power_function, same expression order), the coulomb counting of uav_battery, and the outputs the FMU
 * publishes (consumed, soc, depleted), so that the FMU's step is one foreign call.
 * State slots: the battery slots above, then these; parameters: the power slots, then uav_battery's. */
enum { BAIR = BSTATE, BVZ, BMOTORS, BCONS, BSOC, BDEPL, BSTEP };
enum { WP0, WTIP2, WPI, WV04, WV02, WDRAG, WWEIGHT, WEFF, WAVIONICS, WPOWER };

int uav_battery_step(double *s, const double *p)
{
    const double airspeed = s[BAIR], vz = s[BVZ];
    double demand, cons;
    if (s[BMOTORS] == 0.0) {
        demand = p[WAVIONICS];
    } else {
        const double v2 = airspeed * airspeed;
        const double blade = p[WP0] * (1.0 + 3.0 * v2 / p[WTIP2]);
        const double induced = p[WPI] * sqrt(dmax(0.0, sqrt(1.0 + v2 * v2 / p[WV04]) - v2 / p[WV02]));
        const double shaft = blade + induced + p[WDRAG] * v2 * fabs(airspeed);
        demand = (shaft + dmax(0.0, p[WWEIGHT] * vz)) / p[WEFF] + p[WAVIONICS];
    }
    s[BDEMAND] = demand;
    uav_battery(s, p + WPOWER);
    cons = s[BQ] / p[WPOWER + BCAP];
    s[BCONS] = cons;
    s[BSOC] = dmax(0.0, 1.0 - cons);
    s[BDEPL] = cons >= 1.0;
    return (int)s[BN];
}
