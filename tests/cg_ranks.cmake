# End to end: cassini writes a sheared snapshot; cassini-cg on 1 and 2 ranks must give the same
# fields (to round-off) and a density whose integral is the total mass.
file(REMOVE_RECURSE ${WORK})
execute_process(COMMAND ${EXE} ${CASE} --out ${WORK}/run --set time.end=100 --set output.snapshot_every=100
                        --set particles.count=3000 --set domain.lo=[-1500.0,-1000.0,-10.0] --set domain.hi=[1500.0,1000.0,10.0]
                RESULT_VARIABLE r OUTPUT_QUIET)
if(NOT r EQUAL 0)
  message(FATAL_ERROR "cassini run failed: ${r}")
endif()
file(GLOB snaps ${WORK}/run/snap_*.h5md)
list(GET snaps -1 snap)
execute_process(COMMAND ${MPIEXEC} -n 1 ${MPIFLAGS} ${CG} ${snap} --grid 60x40 --width 100 --out ${WORK}/one.h5 RESULT_VARIABLE r1 OUTPUT_QUIET)
execute_process(COMMAND ${MPIEXEC} -n 2 ${MPIFLAGS} ${CG} ${snap} --grid 60x40 --width 100 --out ${WORK}/two.h5 RESULT_VARIABLE r2 OUTPUT_QUIET)
# Frame selection: the run directory with a time window holding only the last frame (t = 100 s;
# T0 of the ring section is ~5e4 s, so 0.001 T0 ~ 50 s) must give exactly the one-file result,
# and a window holding no frame is an error.
execute_process(COMMAND ${MPIEXEC} -n 1 ${MPIFLAGS} ${CG} ${WORK}/run --frames 0.001T0: --grid 60x40 --width 100 --out ${WORK}/window.h5 RESULT_VARIABLE r3 OUTPUT_QUIET)
execute_process(COMMAND ${MPIEXEC} -n 1 ${MPIFLAGS} ${CG} ${WORK}/run --frames 200: --grid 60x40 --width 100 --out ${WORK}/none.h5 RESULT_VARIABLE r4 OUTPUT_QUIET ERROR_VARIABLE e4)
if(NOT r1 EQUAL 0 OR NOT r2 EQUAL 0 OR NOT r3 EQUAL 0)
  message(FATAL_ERROR "cassini-cg failed: ${r1} ${r2} ${r3}")
endif()
if(r4 EQUAL 0 OR NOT e4 MATCHES "none of the 2 snapshots")
  message(FATAL_ERROR "an empty --frames window was not refused: ${r4} ${e4}")
endif()
execute_process(COMMAND ${PYTHON} -c "
import h5py, numpy as np, sys
a, b, s = h5py.File(sys.argv[1]), h5py.File(sys.argv[2]), h5py.File(sys.argv[3])
for k in ('density', 'momentum', 'kinetic_stress', 'contact_stress', 'background_fluctuation'):
    x, y = a[k][:], b[k][:]
    assert np.allclose(x, y, rtol=1e-12, atol=1e-12 * abs(x).max()), k
mass = s['particles/grains/mass/value'][0].sum()
dx = np.diff(a['grid_x'][:])[0]; dy = np.diff(a['grid_y'][:])[0]
total = a['density'][:].sum() * dx * dy
assert abs(total / mass - 1) < 1e-10, (total, mass)
w = h5py.File(sys.argv[4])
for k in ('density', 'momentum', 'contact_stress'):
    assert np.array_equal(w[k][:], a[k][:]), 'frame window ' + k
print('cg 1 vs 2 ranks agree; integral/mass - 1 =', total / mass - 1, '; --frames window selects the last frame')
" ${WORK}/one.h5 ${WORK}/two.h5 ${snap} ${WORK}/window.h5 RESULT_VARIABLE rp)
if(NOT rp EQUAL 0)
  message(FATAL_ERROR "fields differ between 1 and 2 ranks or lose mass")
endif()
