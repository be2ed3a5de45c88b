#!/usr/bin/env bash
# Builds the relocatable bundle (cassini + Debian's LAMMPS + Debian's Open MPI 4.1 runtime) on
# the Debian 12 machine: a staging copy -> OUT/cassini-bundle.tar.xz, plus the
# scripts that run it (OUT defaults to ./.devbundle: keep it git-ignored, carry it to the many-core machine)
#   make-bundle.sh <cassini build dir> <cassini source checkout> [OUT]
# (cassini's copy of ../shared/tools/many-core/make-bundle.sh: it also carries the source-built
# LAMMPS, LMP_SRC=$(scripts/lammps-source), and scripts/many-core/scaling.py's plan)
# Layout mirrors Debian's (usr/bin, usr/lib/x86_64-linux-gnu/{openmpi,pmix2}, usr/share/openmpi)
# so OPAL_PREFIX=<bundle>/usr relocates Open MPI's configured paths (all are ${prefix}-relative
# except sysconfdir, set by OPAL_SYSCONFDIR). env.sh sets the variables.
set -euo pipefail
BUILD=$(cd "${1:?build dir}" && pwd); SRC=$(cd "${2:?source checkout}" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
SHARED=${MANY_CORE_TOOLS:-$SRC/../shared/tools/many-core}  # run-scaling.sh, env.sh, rsswrap.sh
OUTDIR=${3:-$PWD/.devbundle}; mkdir -p "$OUTDIR"; OUTDIR=$(cd "$OUTDIR" && pwd)
# a staging folder of its own (never a fixed path that could be someone else's), removed on exit
STAGE=$(mktemp -d -t cassini-devbundle.XXXXXX); trap 'rm -rf "$STAGE"' EXIT; B=$STAGE/cassini-bundle
ML=/usr/lib/x86_64-linux-gnu
mkdir -p "$B/usr/bin" "$B/usr/lib/x86_64-linux-gnu/openmpi/lib/openmpi3" \
  "$B/usr/lib/x86_64-linux-gnu/pmix2/lib/pmix" "$B/usr/lib/x86_64-linux-gnu/pmix2/share" \
  "$B/usr/lib/x86_64-linux-gnu/hwloc" "$B/usr/share" "$B/etc/openmpi" "$B/etc/pmix" "$B/glibc" "$B/peers" "$B/scripts"
L=$B/usr/lib/x86_64-linux-gnu

# executables
cp "$BUILD/cassini" "$BUILD/cassini-cg" /usr/bin/lmp /usr/bin/orterun /usr/bin/orted /usr/bin/ompi_info "$B/usr/bin/"
strip --strip-unneeded "$B/usr/bin/cassini" "$B/usr/bin/cassini-cg"
# the Stokes solve's CHOLMOD module, loaded from beside the executable (its libraries join below)
cp "$BUILD/libcassini_cholmod.so" "$B/usr/bin/"
# LAMMPS built from Debian's source (scripts/lammps-source), when there is one
[ -n "${LMP_SRC:-}" ] && [ -x "$LMP_SRC" ] && cp "$LMP_SRC" "$B/usr/bin/lmp-src" && strip --strip-unneeded "$B/usr/bin/lmp-src"
ln -s orterun "$B/usr/bin/mpirun"; ln -s orterun "$B/usr/bin/mpiexec"
# Open MPI plugins, without the fabric ones (UCX, libfabric, PSM, verbs) and OpenSHMEM's
for p in $ML/openmpi/lib/openmpi3/*.so; do
  n=$(basename "$p")
  case "$n" in
    *ucx*|mca_btl_ofi.so|mca_btl_openib.so|mca_mtl_*|mca_atomic_*|mca_memheap_*|mca_scoll_*|mca_spml_*|mca_sshmem_*) continue ;;
  esac
  cp "$p" "$B/usr/lib/x86_64-linux-gnu/openmpi/lib/openmpi3/"
done
cp -r /usr/share/openmpi "$B/usr/share/"
cp $ML/pmix2/lib/pmix/*.so "$B/usr/lib/x86_64-linux-gnu/pmix2/lib/pmix/"
cp -r $ML/pmix2/share/pmix "$B/usr/lib/x86_64-linux-gnu/pmix2/share/"
# Debian's MCA defaults (its sysconfdir is the absolute /etc/openmpi: env.sh points OPAL_SYSCONFDIR here)
grep -v '^#' /etc/openmpi/openmpi-mca-params.conf | grep -v '^$' > "$B/etc/openmpi/openmpi-mca-params.conf"
cp /etc/openmpi/openmpi-default-hostfile "$B/etc/openmpi/"
# PMIx's own conf would name the absolute /usr/.../pmix2/lib/pmix: env.sh sets the path instead
# and points PMIX_SYSCONFDIR at this (empty) one.
echo "# (empty: env.sh sets PMIX_MCA_mca_base_component_path)" > "$B/etc/pmix/pmix-mca-params.conf"

# shared libraries: the closure of everything above, less the glibc core (kept apart in glibc/
# for the explicit-loader fallback on a host with an older glibc)
GLIBC_CORE='^(ld-linux-x86-64\.so\.2|libc\.so\.6|libm\.so\.6|libdl\.so\.2|libpthread\.so\.0|librt\.so\.1|libresolv\.so\.2|libutil\.so\.1|libanl\.so\.1|libmvec\.so\.1|libnsl\.so\.1|libBrokenLocale\.so\.1|libthread_db\.so\.1|libnss_.*|libc_malloc_debug\.so\.0)$'
elfs() { find "$B/usr" -type f \( -name '*.so*' -o -perm -u+x \) -exec sh -c 'head -c4 "$1" | grep -q ELF && echo "$1"' _ {} \; ; }
for round in 1 2 3; do
  for f in $(elfs); do
    ldd "$f" 2>/dev/null | awk '/=> \//{print $1, $3}'
  done | sort -u | while read -r soname path; do
    if [[ "$soname" =~ $GLIBC_CORE ]]; then
      [ -e "$B/glibc/$soname" ] || cp -L "$path" "$B/glibc/$soname"
    else
      [ -e "$L/$soname" ] || cp -L "$path" "$L/$soname"
    fi
  done
done
cp -L /lib64/ld-linux-x86-64.so.2 "$B/glibc/"
for s in libc.so.6 libm.so.6 libdl.so.2 libpthread.so.0 librt.so.1 libresolv.so.2 libutil.so.1 libmvec.so.1; do
  [ -e "$B/glibc/$s" ] || cp -L "$ML/$s" "$B/glibc/$s"
done
# libpmix's own path in Debian (pmix2/lib) as a link, in case something looks there
ln -s ../../libpmix.so.2 "$B/usr/lib/x86_64-linux-gnu/pmix2/lib/libpmix.so.2"

# the project's cases, its benchmark driver (the gas scene) and LAMMPS's input
cp -r "$SRC/cases" "$B/"
cp "$SRC/scripts/bench.py" "$B/scripts/"
cp "${LAMMPS_IN:-$SRC/../shared/peers/lammps/in.gas}" "$B/peers/"  # as scripts/bench.py finds it
cp "$HERE/scaling.py" "$SHARED/env.sh" "$SHARED/rsswrap.sh" "$B/"; chmod +x "$B/scaling.py" "$B/rsswrap.sh"
(cd "$SRC" && git log -1 --format='cassini %H %cd' > "$B/VERSION")
echo "built $(date -u +%FT%TZ) on $(. /etc/os-release; echo "$PRETTY_NAME"), glibc $(getconf GNU_LIBC_VERSION)" >> "$B/VERSION"
lmp -h 2>/dev/null | grep -m1 -i "Large-scale" >> "$B/VERSION" || true
ompi_info | grep -m1 "Open MPI:" >> "$B/VERSION"

du -sh "$B"
tar -C "$STAGE" -cf - cassini-bundle | xz -9e -T2 > "$OUTDIR/cassini-bundle.tar.xz"
cp "$SHARED/run-scaling.sh" "$HERE/scaling.py" "$SHARED/env.sh" "$SHARED/rsswrap.sh" "$OUTDIR/"
ls -la "$OUTDIR"
