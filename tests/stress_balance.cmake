# End to end, stress output: cassini (2 ranks) settles a frictional pile on a floor under
# gravity (tests/settled-pile.toml); its snapshot's wall and body forces and cassini-cg's
# (2 ranks) wall traction, body-force density and stress must satisfy the momentum balance of
# a body at rest: the floor carries the weight, and sigma_xx(x) = int_-inf^x (t_x + F_x) dx'.
# Also: the run's observables.h5md agrees with its last snapshot.
file(REMOVE_RECURSE ${WORK})
execute_process(COMMAND ${MPIEXEC} -n 2 ${MPIFLAGS} ${EXE} ${CASE} --out ${WORK}/run RESULT_VARIABLE r OUTPUT_QUIET)
if(NOT r EQUAL 0)
  message(FATAL_ERROR "cassini run failed: ${r}")
endif()
file(GLOB snaps ${WORK}/run/snap_*.h5md)
list(GET snaps -1 snap)
# A margin of 1.5 mm > the Gaussian's cutoff 3w = 1.2 mm: no kernel is cut at the floor.
execute_process(COMMAND ${MPIEXEC} -n 2 ${MPIFLAGS} ${CG} ${snap} --grid 300 --width 0.0004 --margin 0.0015 --out ${WORK}/fields.h5
                RESULT_VARIABLE r OUTPUT_QUIET)
if(NOT r EQUAL 0)
  message(FATAL_ERROR "cassini-cg failed: ${r}")
endif()
execute_process(COMMAND ${PYTHON} -c "
import h5py, numpy as np, sys
s, f = h5py.File(sys.argv[1]), h5py.File(sys.argv[2])
g = -50.0
mass = s['particles/grains/mass/value'][0]
body = s['particles/grains/body_force/value'][0]
wall = s['contacts/wall_force'][:]
W = -g * mass.sum()
# gravity is the only body force; at rest (kinetic energy ~1e-30 J) the floor carries it all
assert np.allclose(body, mass[:, None] * [g, 0, 0], rtol=1e-14, atol=0), 'body force is not m g'
assert len(wall) > 0 and (s['contacts/wall_point'][:, 0] == 0).all(), 'wall contacts are not on the floor'
assert abs(wall[:, 0].sum() / W - 1) < 1e-6, ('floor does not carry the weight', wall[:, 0].sum(), W)
x = f['grid_x'][:]; h = x[1] - x[0]
t, F, sigma = f['wall_traction'][:, 0], f['body_force_density'][:, 0], f['stress'][:, 0]
assert abs(t.sum() * h / wall[:, 0].sum() - 1) < 1e-10, 'traction integral'
assert abs(F.sum() * h / body[:, 0].sum() - 1) < 1e-10, 'body-force integral'
src = t + F
balance = np.cumsum(src) * h - 0.5 * h * src
err = abs(sigma - balance).max() / abs(sigma).max()
# 8-point line integrals along branches of ~2a = 2.2 w and the cell quadrature: ~0.5 % at most
assert err < 1e-2, ('stress does not balance traction and gravity', err)
# observables.h5md (H5MD observables at their own cadence) against the final snapshot
o = h5py.File(sys.argv[3])
ob = o['observables']
for name in ob:
    assert len(ob[name]['step']) == len(ob[name]['time']) == len(ob[name]['value']), name
assert abs(ob['kinetic_energy/time'][-1] - s['particles/grains/position/time'][0]) < 1e-12, 'last row is not the last frame'
assert ob['particles/value'][-1] == len(mass)
assert ob['contacts/value'][-1] == len(s['contacts/pair_ids']), (ob['contacts/value'][-1], len(s['contacts/pair_ids']))
v = s['particles/grains/velocity/value'][0]
ke = 0.5 * (mass[:, None] * v * v).sum()
assert abs(ob['kinetic_energy/value'][-1] - ke) <= 1e-10 * ke + 1e-300, (ob['kinetic_energy/value'][-1], ke)
assert np.all(np.diff(ob['kinetic_energy/time'][:]) > 0)
print('floor carries', wall[:, 0].sum() / W, 'of the weight; stress balance error', err, 'of the peak')
" ${snap} ${WORK}/fields.h5 ${WORK}/run/observables.h5md RESULT_VARIABLE rp)
if(NOT rp EQUAL 0)
  message(FATAL_ERROR "stress output does not balance")
endif()
