/*
 * rebound_propeller.c -- cases/propeller in REBOUND 5 (public librebound API only): the CPU cost of
 * one orbit of the moonlet's ring patch, the peer of cassini's cases/propeller in scripts/bench-ring.
 *
 * The ring of ../shared/peers/rebound/ring.c (2000 m radial x 18000 m azimuthal, N = 30,000 spheres
 * a = 2 m, rho = 500 kg/m^3, constant e, SEI with dt = T0/1000, shearing sheet, octree collision
 * search, hard spheres, planar) plus the moonlet of cases/propeller at the origin: M = 1.27e10 kg,
 * R = 150 m, fixed. REBOUND has no fixed bodies, so the moonlet is what a REBOUND user writes:
 *   - its gravity, -G M r / max(|r|, R)^3 (cassini's Moonlet), as an additional force: SEI kicks
 *     with it between its two exact epicycle half-drifts;
 *   - its surface, after every step: a particle that has reached it while approaching gets its
 *     normal velocity reversed times e and is put back onto the surface (a hard sphere does not
 *     push out by itself, and the moonlet's pull would otherwise sink the pile into it).
 * The moonlet is not a REBOUND particle: a 150 m sphere in the octree would widen every
 * particle's collision search to its radius. REBOUND's x is radial, y azimuthal.
 *
 * usage: rebound_propeller [N=30000] [e=0.25] [orbits=1] [seed=1]
 * Start as the case files' (dispersion 1 % of the local shear speed, no particle inside the
 * moonlet). Prints one RESULT line; cpu_s times the integration only.
 */
#include "rebound.h"
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static const double G = 6.674e-11;
static const double MOONLET_MASS = 1.27e10, MOONLET_RADIUS = 150.;
static double ring_e = 0.25, particle_radius = 2.;
static long moonlet_impacts = 0;

static double restitution_const(const struct reb_simulation* const r, double v){
    (void)r; (void)v;
    return ring_e;
}

static void moonlet_gravity(struct reb_simulation* const r){
    struct reb_particle* const p = r->particles;
    const double gm = G * MOONLET_MASS;
    for (size_t i = 0; i < r->N; i++){
        const double d = fmax(sqrt(p[i].x * p[i].x + p[i].y * p[i].y), MOONLET_RADIUS);
        const double s = -gm / (d * d * d);
        p[i].ax += s * p[i].x;
        p[i].ay += s * p[i].y;
    }
}

/* After every step: planar layer (as ring.c) and the moonlet's surface. */
static void after_step(struct reb_simulation* const r){
    struct reb_particle* const p = r->particles;
    const double reach = MOONLET_RADIUS + particle_radius;
    for (size_t i = 0; i < r->N; i++){
        p[i].z = 0.; p[i].vz = 0.;
        const double d2 = p[i].x * p[i].x + p[i].y * p[i].y;
        if (d2 >= reach * reach) continue;
        const double d = sqrt(d2), nx = p[i].x / d, ny = p[i].y / d;
        const double vn = p[i].vx * nx + p[i].vy * ny;
        if (vn < 0.){
            p[i].vx -= (1. + ring_e) * vn * nx;
            p[i].vy -= (1. + ring_e) * vn * ny;
            moonlet_impacts++;
        }
        p[i].x = reach * nx;
        p[i].y = reach * ny;
    }
}

static void dispersion(const struct reb_simulation* r, double* sx, double* sy){
    const size_t n = r->N;
    double mx = 0., my = 0.;
    for (size_t i = 0; i < n; i++){ mx += r->particles[i].vx; my += r->particles[i].vy + 1.5 * r->OMEGA * r->particles[i].x; }
    mx /= (double)n; my /= (double)n;
    double vx2 = 0., vy2 = 0.;
    for (size_t i = 0; i < n; i++){
        const double dx = r->particles[i].vx - mx, dy = r->particles[i].vy + 1.5 * r->OMEGA * r->particles[i].x - my;
        vx2 += dx * dx; vy2 += dy * dy;
    }
    *sx = sqrt(vx2 / (double)n); *sy = sqrt(vy2 / (double)n);
}

int main(int argc, char* argv[]){
    const long N = argc > 1 ? atol(argv[1]) : 30000;
    ring_e = argc > 2 ? atof(argv[2]) : 0.25;
    const double orbits = argc > 3 ? atof(argv[3]) : 1.0;
    const unsigned int seed = argc > 4 ? (unsigned int)strtoul(argv[4], NULL, 10) : 1u;
    const double OMEGA0 = 1.5385e-4, T0 = 2. * M_PI / OMEGA0, a = particle_radius;
    const double mass = 500. * 4. / 3. * M_PI * a * a * a, Lx = 2000., Ly = 18000., root = 2000.;
    if (N < 1 || N > 100000 || orbits <= 0. || ring_e < 0. || ring_e > 1.){
        fprintf(stderr, "usage: %s [0<N<=100000] [0<=e<=1] [orbits>0] [seed]\n", argv[0]);
        return 2;
    }

    struct reb_simulation* r = reb_simulation_create();
    r->rand_seed = seed;
    reb_simulation_set_integrator(r, "sei");
    r->OMEGA = OMEGA0;
    r->dt = T0 / 1000.;
    r->boundary = REB_BOUNDARY_SHEAR;
    r->gravity = REB_GRAVITY_NONE;
    r->additional_forces = moonlet_gravity;
    r->collision = REB_COLLISION_TREE;
    r->collision_resolve = reb_collision_resolve_hardsphere;
    r->coefficient_of_restitution = restitution_const;
    r->minimum_collision_velocity = a * OMEGA0 * 1e-3;  /* as ring.c */
    r->root_size = root;
    r->N_root_x = 1;
    r->N_root_y = 9;
    r->N_root_z = 1;
    r->N_ghost_x = 1;
    r->N_ghost_y = 1;
    r->N_ghost_z = 0;
    r->heartbeat = after_step;

    /* Random sequential placement without overlaps, outside the moonlet (a cell list of 2a cells). */
    const long ncx = (long)(Lx / (2 * a)), ncy = (long)(Ly / (2 * a));
    const double csx = Lx / (double)ncx, csy = Ly / (double)ncy;
    long* head = malloc(sizeof(long) * (size_t)(ncx * ncy));
    long* next = malloc(sizeof(long) * (size_t)N);
    double* px = malloc(sizeof(double) * (size_t)N);
    double* py = malloc(sizeof(double) * (size_t)N);
    if (!head || !next || !px || !py){ fprintf(stderr, "out of memory\n"); return 1; }
    for (long c = 0; c < ncx * ncy; c++) head[c] = -1;
    for (long i = 0; i < N; i++){
        double x, y;
        long cx, cy;
        for (;;){
            x = reb_random_uniform(r, -Lx / 2., Lx / 2.);
            y = reb_random_uniform(r, -Ly / 2., Ly / 2.);
            if (x * x + y * y < (MOONLET_RADIUS + a) * (MOONLET_RADIUS + a)) continue;
            cx = (long)((x + Lx / 2.) / csx); if (cx >= ncx) cx = ncx - 1;
            cy = (long)((y + Ly / 2.) / csy); if (cy >= ncy) cy = ncy - 1;
            int ok = 1;
            for (long dx = -1; dx <= 1 && ok; dx++)
                for (long dy = -1; dy <= 1 && ok; dy++){
                    const long c = ((cx + dx + ncx) % ncx) * ncy + (cy + dy + ncy) % ncy;
                    for (long j = head[c]; j >= 0; j = next[j]){
                        double ddx = x - px[j], ddy = y - py[j];
                        ddx -= Lx * round(ddx / Lx);
                        ddy -= Ly * round(ddy / Ly);
                        if (ddx * ddx + ddy * ddy < 4 * a * a){ ok = 0; break; }
                    }
                }
            if (ok) break;
        }
        px[i] = x; py[i] = y;
        next[i] = head[cx * ncy + cy]; head[cx * ncy + cy] = i;
        const double s = 0.01 * 1.5 * OMEGA0 * fabs(x);  /* the case files' dispersion = 0.01 */
        struct reb_particle p = {0};
        p.x = x; p.y = y;
        p.vx = reb_random_normal(r, s * s);
        p.vy = -1.5 * OMEGA0 * x + reb_random_normal(r, s * s);
        p.r = a;
        p.m = mass;
        reb_simulation_add(r, p);
    }
    free(head); free(next); free(px); free(py);

    const size_t steps = (size_t)llround(orbits * 1000.);
    const clock_t c0 = clock();
    reb_simulation_steps(r, steps);
    const double cpu_s = (double)(clock() - c0) / CLOCKS_PER_SEC;
    reb_simulation_synchronize(r);
    double sx, sy;
    dispersion(r, &sx, &sy);
    long on_moonlet = 0;
    for (size_t i = 0; i < r->N; i++){
        const double d = sqrt(r->particles[i].x * r->particles[i].x + r->particles[i].y * r->particles[i].y);
        on_moonlet += d < MOONLET_RADIUS + a + 0.5 * a;
    }
    printf("RESULT code=rebound-propeller N=%zu e=%g orbits=%g seed=%u cpu_s=%.3f steps=%llu collisions=%lld "
           "moonlet_impacts=%ld on_moonlet=%ld sigma_radial=%.4f sigma_azimuthal=%.4f cpu_per_orbit=%.3f\n",
           r->N, ring_e, orbits, seed, cpu_s, (unsigned long long)r->steps_done, (long long)r->collisions_log_n,
           moonlet_impacts, on_moonlet, sx / (a * OMEGA0), sy / (a * OMEGA0), cpu_s / orbits);
    reb_simulation_free(r);
    return 0;
}
