#!/usr/bin/env bash
# Regenerate the CalculiX reference for the half-disc (data/finger/half-disc.toml):
# haptex mesh export -> decks -> ccx runs -> CSVs -> comparison with haptex.
#
#   validation/calculix/run.sh            the reference (haptex curves, decks, 8 ccx jobs, CSVs, comparison)
#   validation/calculix/run.sh variants   also the 10 bump variants of decks/variants/ (~30 min more)
#   validation/calculix/run.sh flat_linear press_linear_C3D8   only these ccx jobs
#
# HAPTEX: the haptex binary (default: target/release/haptex of this checkout,
# else /work/main's); CCX: the CalculiX solver (default: ccx on PATH);
# CCX_TIMEOUT: wall-clock limit per ccx run in s (default 900).
# Scratch (haptex VTK, ccx run directories) goes to work/ and runs/ (git-ignored);
# results/runs.log gets one line per ccx run (rc, wall time, last converged
# time: press 0..1, then 1 + x for the slide), results/ccx/ the .sta files.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
REPO="$(git -C "$HERE" rev-parse --show-toplevel)"
if [[ -z "${HAPTEX:-}" ]]; then
    HAPTEX="$REPO/target/release/haptex"
    [[ -x "$HAPTEX" ]] || HAPTEX=/work/main/target/release/haptex
fi
CCX="${CCX:-ccx}"
CCX_TIMEOUT="${CCX_TIMEOUT:-900}"
FINGER="$REPO/data/finger/half-disc.toml"
PY=/usr/bin/python3   # the Debian python3 with python3-numpy
export OMP_NUM_THREADS=1 CCX_NPROC_EQUATION_SOLVER=1 CCX_NPROC_STIFFNESS=1 CCX_NPROC_RESULTS=1
cd "$HERE"
mkdir -p work runs results/haptex decks

echo "== versions (also in results/provenance.txt)"
{
    echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
    echo "ccx: $("$CCX" -v 2>&1 | grep -m1 -i version | sed 's/^ *//') ($(command -v "$CCX"); Debian package $(dpkg-query -W -f='${Package} ${Version}' calculix-ccx 2>/dev/null || echo '?'))"
    echo "haptex: $("$HAPTEX" --version) ($HAPTEX, sha256 $(sha256sum "$HAPTEX" | cut -d' ' -f1), modified $(date -u -r "$HAPTEX" +%Y-%m-%dT%H:%M:%SZ))"
    hrepo="$(git -C "$(dirname "$HAPTEX")" rev-parse --show-toplevel 2>/dev/null || true)"
    [[ -n "$hrepo" ]] && echo "haptex checkout: $hrepo at $(git -C "$hrepo" rev-parse HEAD)$(git -C "$hrepo" diff --quiet HEAD -- crates 2>/dev/null || echo ' (crates/ modified)') (the binary may be older than HEAD)"
    echo "this checkout: $(git -C "$REPO" rev-parse HEAD) ($(git -C "$REPO" rev-parse --abbrev-ref HEAD))"
    echo "machine: $(lscpu | sed -n 's/^Model name: *//p'), $(nproc --all) CPUs, $(lscpu | sed -n 's/^Hypervisor vendor: *//p') guest, $(free -g | awk '/Mem:/ {print $2}') GB, Linux $(uname -r)"
    echo "threads: OMP_NUM_THREADS=$OMP_NUM_THREADS"
} | tee results/provenance.txt

echo "== haptex mesh export (frame 0 = after the 0.25 mm press; reference node positions)"
rm -rf work/mesh_vtk
"$HAPTEX" simulate --finger "$FINGER" --material elastic --surface flat --slide 0.2 \
    --vtk work/mesh_vtk --vtk-every 1000 -q -o work/mesh_profile.csv

echo "== decks"
"$PY" make_decks.py work/mesh_vtk/frame_0000.vtu --out decks

echo "== haptex's own curves (small strain, B-bar Q4, elastic)"
"$HAPTEX" simulate --finger "$FINGER" --material elastic --surface flat -q \
    -o results/haptex/flat.csv --history results/haptex/flat_history.csv
"$HAPTEX" simulate --finger "$FINGER" --material elastic --surface bump --x0 5 --width 1.5 --height 0.3 -q \
    -o results/haptex/bump.csv --history results/haptex/bump_history.csv
# haptex's finite-strain option, where the binary has it (added on main on 2026-11-25):
# compared with the NLGEOM runs
rm -f results/haptex/*_finite*.csv
if "$HAPTEX" simulate --help | grep -q -- '--kinematics'; then
    "$HAPTEX" simulate --finger "$FINGER" --material elastic --kinematics finite --surface flat -q \
        -o results/haptex/flat_finite.csv --history results/haptex/flat_finite_history.csv
    "$HAPTEX" simulate --finger "$FINGER" --material elastic --kinematics finite --surface bump --x0 5 --width 1.5 --height 0.3 -q \
        -o results/haptex/bump_finite.csv --history results/haptex/bump_finite_history.csv
fi
rm -rf work/press_*
"$HAPTEX" simulate --finger "$FINGER" --material elastic --surface flat --slide 0.2 --mu-skin 0 -q \
    -o work/press_mu0.csv --history results/haptex/press_mu0_history.csv
for d in 0.025 0.05 0.075 0.1 0.125 0.15 0.175 0.2 0.225 0.25; do
    "$HAPTEX" simulate --finger "$FINGER" --material elastic --surface flat --indent "$d" --slide 0.2 -q \
        --vtk "work/press_$d" --vtk-every 1000 -o "work/press_$d.csv"
done

echo "== CalculiX runs"
REFERENCE=(press_linear_C3D8I_mu0 press_linear_C3D8 press_nlgeom_C3D8 press_nlgeomsvk_C3D8I
           flat_linear flat_nlgeom bump_linear bump_nlgeom)
VARIANTS=()
for f in decks/variants/*.inp; do
    case "$(basename "$f")" in strip_*) ;; *) VARIANTS+=("$(basename "$f" .inp)") ;; esac
done
JOBS=("$@")
if [[ ${#JOBS[@]} -eq 0 ]]; then
    JOBS=("${REFERENCE[@]}")
elif [[ "${JOBS[*]}" == variants ]]; then
    JOBS=("${REFERENCE[@]}" "${VARIANTS[@]}")
fi
mkdir -p results/ccx
for job in "${JOBS[@]}"; do
    rm -rf "runs/$job"
    mkdir -p "runs/$job/variants"
    cp decks/*.inp "runs/$job/"
    cp decks/variants/strip_*.inp "runs/$job/variants/"
    [[ -f "decks/$job.inp" ]] || cp "decks/variants/$job.inp" "runs/$job/"
    start=$(date +%s.%N)
    set +e
    (cd "runs/$job" && timeout "$CCX_TIMEOUT" "$CCX" -i "$job" > ccx.log 2>&1)
    rc=$?
    set -e
    wall=$(echo "$(date +%s.%N) - $start" | bc)
    # the last converged increment (a line of the .sta without U in the attempt column)
    last=$(awk 'NF == 7 && $1 ~ /^[0-9]+$/ && $3 !~ /U/ {t = $5} END {print t}' "runs/$job/$job.sta")
    status=$(grep -m1 -o '\*ERROR[^*]*' "runs/$job/ccx.log" | tr -s ' \n' ' ' || true)
    [[ $rc -eq 124 ]] && status="stopped by the ${CCX_TIMEOUT} s time limit"
    printf '%s %-36s rc=%-3d wall=%7.1f s  last converged total time=%-13s %s\n' \
        "$(date -u +%FT%TZ)" "$job" "$rc" "$wall" "$last" "$status" | tee -a results/runs.log
    cp "runs/$job/$job.sta" results/ccx/
done

echo "== extraction"
rm -rf work/dat
mkdir -p work/dat
for d in runs/*/; do
    job=$(basename "$d")
    [[ -f "$d/$job.dat" ]] && cp "$d/$job.dat" work/dat/
done
"$PY" extract.py work/dat --decks decks --out results
"$PY" compare.py --results results --haptex-vtk work
