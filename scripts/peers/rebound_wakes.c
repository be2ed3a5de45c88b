/*
 * rebound_wakes.c -- the gravity-wakes patch in REBOUND, for the side-by-side numbers in
 * docs/rings.md (built and run by scripts/gravity-wakes-rebound; analysed by
 * scripts/gravity_wakes.py like a cassini run).
 *
 * The set-up of REBOUND's examples/shearing_sheet (public API only): SEI integrator,
 * dt = T0/1000, shearing-sheet boundary, tree gravity (opening_angle2 = 0.5, softening 0.1 m),
 * tree collisions with hard spheres and the Bridges restitution 0.32 (100 v)^-0.234, Omega0 =
 * 1.3143527e-4 1/s, Sigma = 400 kg/m^2, rho = 400 kg/m^3, radii 1-4 m with dN/da ~ a^-3, z
 * Gaussian of 1 m, on the shear flow without dispersion, a box of 2 x 2 root boxes.
 *
 * usage: rebound_wakes OUTDIR [orbits=5] [box=200] [seed=1]
 * Writes OUTDIR/snap_NNNN.txt ten times per orbit in cassini's axes (x azimuthal = -y_REBOUND,
 * y radial = x_REBOUND, z): a header line "# time Lx Ly Lz omega" then "x y z vx vy vz radius mass".
 */
#include "rebound.h"
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static double bridges(const struct reb_simulation* const r, double v){
    (void)r;
    double e = 0.32 * pow(fabs(v) * 100., -0.234);
    return e > 1. ? 1. : e;
}

static const char* outdir;
static double box, next_out = 0.;
static int frame = 0;

static void write_frame(struct reb_simulation* const r){
    char path[4096];
    snprintf(path, sizeof path, "%s/snap_%04d.txt", outdir, frame++);
    FILE* f = fopen(path, "w");
    if (!f){ perror(path); exit(1); }
    fprintf(f, "# %.17g %.17g %.17g %.17g %.17g\n", r->t, box, box, r->root_size, r->OMEGA);
    for (size_t i = 0; i < r->N; i++){
        const struct reb_particle p = r->particles[i];
        fprintf(f, "%.10g %.10g %.10g %.10g %.10g %.10g %.6g %.6g\n", -p.y, p.x, p.z, -p.vy, p.vx, p.vz, p.r, p.m);
    }
    fclose(f);
}

static void heartbeat(struct reb_simulation* const r){
    if (r->t >= next_out - 1e-9 * r->dt){
        write_frame(r);
        next_out += 0.1 * 2. * M_PI / r->OMEGA;
    }
}

int main(int argc, char* argv[]){
    if (argc < 2){ fprintf(stderr, "usage: %s OUTDIR [orbits] [box] [seed]\n", argv[0]); return 2; }
    outdir = argv[1];
    const double orbits = argc > 2 ? atof(argv[2]) : 5.;
    box = argc > 3 ? atof(argv[3]) : 200.;
    struct reb_simulation* r = reb_simulation_create();
    r->rand_seed = argc > 4 ? (unsigned int)strtoul(argv[4], NULL, 10) : 1u;
    r->opening_angle2 = .5;
    reb_simulation_set_integrator(r, "sei");
    r->boundary = REB_BOUNDARY_SHEAR;
    r->gravity = REB_GRAVITY_TREE;
    r->collision = REB_COLLISION_TREE;
    r->collision_resolve = reb_collision_resolve_hardsphere;
    r->coefficient_of_restitution = bridges;
    r->OMEGA = 0.00013143527;
    r->G = 6.67428e-11;
    r->softening = 0.1;
    r->dt = 1e-3 * 2. * M_PI / r->OMEGA;
    r->minimum_collision_velocity = 1. * r->OMEGA * 0.001;
    r->heartbeat = heartbeat;
    r->root_size = box / 2.;
    r->N_root_x = 2; r->N_root_y = 2; r->N_root_z = 1;
    r->N_ghost_x = 2; r->N_ghost_y = 2; r->N_ghost_z = 0;
    const double total = 400. * box * box;
    double mass = 0.;
    while (mass < total){
        struct reb_particle p = {0};
        p.x = reb_random_uniform(r, -box / 2., box / 2.);
        p.y = reb_random_uniform(r, -box / 2., box / 2.);
        p.z = reb_random_normal(r, 1.);
        p.vy = -1.5 * p.x * r->OMEGA;
        p.r = reb_random_powerlaw(r, 1., 4., -3.);
        p.m = 400. * 4. / 3. * M_PI * p.r * p.r * p.r;
        reb_simulation_add(r, p);
        mass += p.m;
    }
    const clock_t c0 = clock();
    reb_simulation_integrate(r, orbits * 2. * M_PI / r->OMEGA);
    fprintf(stdout, "RESULT N=%zu orbits=%g cpu_per_orbit=%.3f\n", r->N, orbits,
            (double)(clock() - c0) / CLOCKS_PER_SEC / orbits);
    reb_simulation_free(r);
    return 0;
}
