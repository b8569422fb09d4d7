#!/usr/bin/env bash
# CalculiX 3D reference for haptex's 3D fingertip (data/finger/half-disc.toml):
# haptex runs (curves + VTK mesh export) -> decks -> ccx runs -> CSVs -> comparison.
#
#   validation/calculix3d/run.sh                 every job below, one at a time
#   validation/calculix3d/run.sh flat_linear     only these ccx jobs (haptex runs always)
#   validation/calculix3d/run.sh diagnosis       the bump diagnosis jobs (README, "Diagnosis of the bump"):
#                                                frictionless and small-increment runs, ~40 min
#   validation/calculix3d/run.sh nlgeom_press    the finite-strain press jobs (README, "NLGEOM, the press
#                                                alone"), ~50 min (the default mesh's C3D20R runs ~20 min each)
#   validation/calculix3d/run.sh nlgeom_slide    the finite-strain slides (README, "NLGEOM, the slide"): the flat
#                                                with C3D20R (NLGEOM and linear) and C3D8 (NLGEOM), the bump with
#                                                C3D8 (NLGEOM and linear), ~25 min
#   validation/calculix3d/run.sh nlgeom_slide_failed   the runs of that section that failed, ~40 min
#
# The timing of the peer comparison: whenever flat_linear is run, this script
# times `haptex simulate` on the same case and mesh right before the ccx run,
# and writes both wall times and their ratio to results/timing.txt.
#
# HAPTEX: haptex binary (default /tmp/ccx3d/haptex, a copy of /work/main/target/ci/haptex,
# else target/ci/haptex of this checkout); CCX: the solver (default ccx);
# CCX_TIMEOUT: wall limit per ccx run in s (default 900).
# Scratch goes to work/ and runs/ (not for git); results/ gets the CSVs,
# runs.log (one line per run), ccx/ (the .sta files), provenance.txt, timing.txt.
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
REPO="$(git -C "$HERE" rev-parse --show-toplevel)"
if [[ -z "${HAPTEX:-}" ]]; then
    HAPTEX=/tmp/ccx3d/haptex
    [[ -x "$HAPTEX" ]] || HAPTEX="$REPO/target/ci/haptex"
fi
CCX="${CCX:-ccx}"
CCX_TIMEOUT="${CCX_TIMEOUT:-900}"
FINGER="$REPO/data/finger/half-disc.toml"
PY="${PY:-python3}"   # a python3 with numpy
export OMP_NUM_THREADS=1 CCX_NPROC_EQUATION_SOLVER=1 CCX_NPROC_STIFFNESS=1 CCX_NPROC_RESULTS=1
cd "$HERE"
mkdir -p work runs results/haptex results/ccx decks

BUMP=(--x0 1.5 --width 1.5 --height 0.2)
COMMON=(--model 3d --finger "$FINGER" --material elastic --indent 0.5 --slide 3 --step 0.1 --direction-deg 0 -q)

echo "== provenance (results/provenance.txt)"
{
    echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
    echo "ccx: $("$CCX" -v 2>&1 | grep -m1 -i version | sed 's/^ *//') ($(command -v "$CCX"); Debian package $(dpkg-query -W -f='${Package} ${Version}' calculix-ccx 2>/dev/null || echo '?'))"
    echo "haptex: $("$HAPTEX" --version) ($HAPTEX, sha256 $(sha256sum "$HAPTEX" | cut -d' ' -f1), modified $(date -u -r "$HAPTEX" +%Y-%m-%dT%H:%M:%SZ))"
    echo "checkout: $REPO at $(git -C "$REPO" rev-parse HEAD) ($(git -C "$REPO" rev-parse --abbrev-ref HEAD))"
    echo "machine: $(lscpu | sed -n 's/^Model name: *//p'), $(nproc --all) CPUs, L1d $(lscpu | sed -n 's/^L1d cache: *//p'), L2 $(lscpu | sed -n 's/^L2 cache: *//p'), L3 $(lscpu | sed -n 's/^L3 cache: *//p'), $(lscpu | sed -n 's/^Hypervisor vendor: *//p') guest, $(free -g | awk '/Mem:/ {print $2}') GB, Linux $(uname -r)"
    echo "threads: OMP_NUM_THREADS=$OMP_NUM_THREADS (the other core was in use by another engineer's builds)"
} | tee results/provenance.txt

echo "== haptex curves and mesh export (frame 0 = after the press; reference positions)"
for mesh in coarse default; do
    for surf in flat bump; do
        extra=(); [[ $surf == bump ]] && extra=("${BUMP[@]}")
        rm -rf "work/vtk_${surf}_$mesh"
        "$HAPTEX" simulate "${COMMON[@]}" --mesh $mesh --surface $surf "${extra[@]}" \
            -o "results/haptex/${surf}_$mesh.csv" --history "results/haptex/${surf}_${mesh}_history.csv" \
            --vtk "work/vtk_${surf}_$mesh" --vtk-every 1000
    done
done

echo "== haptex on the bump: frictionless (--mu-skin 0), all meshes, and mu 0.5 on the fine mesh (the diagnosis)"
for mesh in coarse default fine; do
    "$HAPTEX" simulate "${COMMON[@]}" --mesh $mesh --surface bump "${BUMP[@]}" --mu-skin 0 \
        -o "results/haptex/bump_${mesh}_mu0.csv" --history "results/haptex/bump_${mesh}_mu0_history.csv"
done
"$HAPTEX" simulate "${COMMON[@]}" --mesh fine --surface bump "${BUMP[@]}" \
    -o results/haptex/bump_fine.csv --history results/haptex/bump_fine_history.csv

echo "== haptex at finite strain (--kinematics finite): the flat and the bump, coarse and default mesh"
"$HAPTEX" simulate "${COMMON[@]}" --kinematics finite --mesh coarse --surface flat \
    -o results/haptex/flat_coarse_finite.csv --history results/haptex/flat_coarse_finite_history.csv
"$HAPTEX" simulate "${COMMON[@]}" --kinematics finite --mesh default --surface flat \
    -o results/haptex/flat_default_finite.csv --history results/haptex/flat_default_finite_history.csv
"$HAPTEX" simulate "${COMMON[@]}" --kinematics finite --mesh coarse --surface bump "${BUMP[@]}" \
    -o results/haptex/bump_coarse_finite.csv --history results/haptex/bump_coarse_finite_history.csv
"$HAPTEX" simulate "${COMMON[@]}" --kinematics finite --mesh default --surface bump "${BUMP[@]}" \
    -o results/haptex/bump_default_finite.csv --history results/haptex/bump_default_finite_history.csv

echo "== decks"
mk() { "$PY" make_decks.py "$@" --out decks; }
# the reference contact: surface-to-surface penalty, 200 N/mm^3, mu 0.5, stick slope 20 N/mm^3
# (node-to-surface, and a stick slope of 200, stall on the bump: the *_n2s jobs)
S2S=(--contact "SURFACE TO SURFACE" --stick 20)
FC=work/vtk_flat_coarse/frame_0000.vtu
BC=work/vtk_bump_coarse/frame_0000.vtu
mk $FC --job flat_linear --surface flat "${S2S[@]}"
mk $FC --job flat_linear_n2s --surface flat --contact "NODE TO SURFACE" --stick 200
mk $FC --job flat_linear_C3D8 --surface flat "${S2S[@]}" --etype C3D8
mk work/vtk_flat_default/frame_0000.vtu --job flat_linear_default --surface flat "${S2S[@]}" --slide 1
mk $FC --job flat_nlgeom --surface flat "${S2S[@]}" --kin nlgeom
mk $BC --job bump_linear --surface bump "${BUMP[@]}" "${S2S[@]}"
mk $BC --job bump_nlgeom --surface bump "${BUMP[@]}" "${S2S[@]}" --kin nlgeom
mk $BC --job bump_linear_n2s --surface bump "${BUMP[@]}" --contact "NODE TO SURFACE" --stick 200
mk $BC --job bump_linear_n2s_stick20 --surface bump "${BUMP[@]}" --contact "NODE TO SURFACE" --stick 20
# the diagnosis of the bump (README, "Diagnosis of the bump"): frictionless, both contact types;
# surface-to-surface with slide increments of 0.025 and 0.01 mm (instead of 0.1)
mk $BC --job bump_mu0_n2s --surface bump "${BUMP[@]}" --mu 0 --contact "NODE TO SURFACE"
mk $BC --job bump_mu0_s2s --surface bump "${BUMP[@]}" --mu 0 --contact "SURFACE TO SURFACE"
mk $BC --job bump_mu0_s2s_inc025 --surface bump "${BUMP[@]}" --mu 0 --contact "SURFACE TO SURFACE" --inc 0.025
mk $BC --job bump_mu0_s2s_inc01 --surface bump "${BUMP[@]}" --mu 0 --contact "SURFACE TO SURFACE" --inc 0.01
mk $BC --job bump_mu0_s2s_nlgeom --surface bump "${BUMP[@]}" --mu 0 --contact "SURFACE TO SURFACE" --kin nlgeom
mk $BC --job bump_linear_inc025 --surface bump "${BUMP[@]}" "${S2S[@]}" --inc 0.025
mk $BC --job bump_linear_inc01 --surface bump "${BUMP[@]}" "${S2S[@]}" --inc 0.01
# node-to-surface at mu 0.5 again (none gets through the bump): stick slope 2, longer iterations, both
CTRL="*CONTROLS, PARAMETERS=TIME INCREMENTATION;8,16,9,200,10,4,,5"
mk $BC --job bump_linear_n2s_stick2 --surface bump "${BUMP[@]}" --contact "NODE TO SURFACE" --stick 2
mk $BC --job bump_linear_n2s_ctrl --surface bump "${BUMP[@]}" --contact "NODE TO SURFACE" --stick 200 --controls "$CTRL"
mk $BC --job bump_linear_n2s_stick2_ctrl --surface bump "${BUMP[@]}" --contact "NODE TO SURFACE" --stick 2 --controls "$CTRL"

# finite strain, the press alone (2026-12-07): frictionless, NLGEOM against linear, three elements on
# the coarse mesh and the quadratic C3D20R (a node at each edge's middle) on the default one
PRESS_JOBS=()
for e in C3D8I C3D8 C3D20R; do
    for kin in linear nlgeom; do
        mk $FC --job press_mu0_${kin}_$e --surface flat --mu 0 "${S2S[@]}" --etype $e --kin $kin --slide 0
        PRESS_JOBS+=(press_mu0_${kin}_$e)
    done
done
for kin in linear nlgeom; do
    mk work/vtk_flat_default/frame_0000.vtu --job press_mu0_${kin}_C3D20R_default --surface flat --mu 0 "${S2S[@]}" \
        --etype C3D20R --kin $kin --slide 0
    PRESS_JOBS+=(press_mu0_${kin}_C3D20R_default)
done

# finite strain, the slide (2026-12-08; README, "NLGEOM, the slide"). The flat with the quadratic C3D20R
# and with plain C3D8 (C3D8I's incompatible modes diverge under NLGEOM once the pad slips: flat_nlgeom),
# NLGEOM and linear. The bump with plain C3D8 in 0.025 mm slide increments (surface-to-surface contact's
# increment error on the bump: "Diagnosis of the bump"), its press printed at every increment (with the
# press's time points CalculiX 2.20 failed on a zero increment after a cutback: the *_C3D8_inc025 jobs)
mk $FC --job flat_nlgeom_C3D20R --surface flat "${S2S[@]}" --etype C3D20R --kin nlgeom
mk $FC --job flat_linear_C3D20R --surface flat "${S2S[@]}" --etype C3D20R
mk $FC --job flat_nlgeom_C3D8 --surface flat "${S2S[@]}" --etype C3D8 --kin nlgeom
for kin in nlgeom linear; do
    mk $BC --job bump_${kin}_C3D8_inc025_pe --surface bump "${BUMP[@]}" "${S2S[@]}" --etype C3D8 --kin $kin --inc 0.025 \
        --press-every-increment
done
SLIDE_JOBS=(flat_nlgeom_C3D20R flat_linear_C3D20R flat_nlgeom_C3D8 bump_nlgeom_C3D8_inc025_pe bump_linear_C3D8_inc025_pe)
# what did not get through (README, "What failed"): stick slope 200 with C3D20R on the flat; the bump with
# C3D20R (NLGEOM: x = 1.075 mm after 20 min) and with C3D8 and the press's time points
STICK200=(--contact "SURFACE TO SURFACE" --stick 200)
mk $FC --job flat_nlgeom_C3D20R_stick200 --surface flat "${STICK200[@]}" --etype C3D20R --kin nlgeom
mk $FC --job flat_linear_C3D20R_stick200 --surface flat "${STICK200[@]}" --etype C3D20R
for e in C3D20R C3D8; do
    for kin in nlgeom linear; do
        mk $BC --job bump_${kin}_${e}_inc025 --surface bump "${BUMP[@]}" "${S2S[@]}" --etype $e --kin $kin --inc 0.025
    done
done
SLIDE_FAILED_JOBS=(flat_nlgeom_C3D20R_stick200 flat_linear_C3D20R_stick200 bump_nlgeom_C3D20R_inc025 bump_linear_C3D20R_inc025
    bump_nlgeom_C3D8_inc025 bump_linear_C3D8_inc025)

JOBS=("$@")
[[ ${#JOBS[@]} -eq 0 ]] && JOBS=(flat_linear flat_linear_n2s bump_linear flat_nlgeom flat_linear_C3D8 flat_linear_default bump_nlgeom bump_linear_n2s bump_linear_n2s_stick20)
[[ ${JOBS[*]} == nlgeom_press ]] && JOBS=("${PRESS_JOBS[@]}")
[[ ${JOBS[*]} == nlgeom_slide ]] && JOBS=("${SLIDE_JOBS[@]}")
[[ ${JOBS[*]} == nlgeom_slide_failed ]] && JOBS=("${SLIDE_FAILED_JOBS[@]}")
[[ ${JOBS[*]} == diagnosis ]] && JOBS=(bump_mu0_n2s bump_mu0_s2s bump_mu0_s2s_inc025 bump_mu0_s2s_inc01 bump_linear_inc025 bump_linear_inc01 bump_mu0_s2s_nlgeom bump_linear_n2s_stick2 bump_linear_n2s_ctrl bump_linear_n2s_stick2_ctrl)

echo "== CalculiX runs"
for job in "${JOBS[@]}"; do
    if [[ $job == flat_linear ]]; then
        # the peer timing: haptex's CLI on the same case and mesh, just before the ccx run
        hstart=$(date +%s.%N)
        "$HAPTEX" simulate "${COMMON[@]}" --mesh coarse --surface flat -o work/timed_flat.csv
        hwall=$(echo "$(date +%s.%N) - $hstart" | bc)
        cmp -s work/timed_flat.csv results/haptex/flat_coarse.csv || echo "note: the timed haptex run's profile differs from results/haptex/flat_coarse.csv"
    fi
    rm -rf "runs/$job"
    mkdir -p "runs/$job"
    cp "decks/$job.inp" "runs/$job/"
    start=$(date +%s.%N)
    set +e
    (cd "runs/$job" && timeout "$CCX_TIMEOUT" "$CCX" -i "$job" > ccx.log 2>&1)
    rc=$?
    set -e
    wall=$(echo "$(date +%s.%N) - $start" | bc)
    last=$(awk 'NF == 7 && $1 ~ /^[0-9]+$/ && $3 !~ /U/ {t = $5} END {print t}' "runs/$job/$job.sta")
    status=$(grep -m1 -o '\*ERROR[^*]*' "runs/$job/ccx.log" | tr -s ' \n' ' ' || true)
    [[ $rc -eq 124 ]] && status="stopped by the ${CCX_TIMEOUT} s time limit"
    [[ $rc -eq 0 && -z "$status" ]] && status="completed"
    printf '%s ccx:%-22s rc=%-3d wall=%7.1f s  last converged total time=%-13s (press 0..1, then 1 + x) %s\n' \
        "$(date -u +%FT%TZ)" "$job" "$rc" "$wall" "$last" "$status" | tee -a results/runs.log
    cp "runs/$job/$job.sta" results/ccx/
    rm -f "results/$job.csv" "results/${job}_press.csv"
    [[ -f "runs/$job/$job.dat" ]] && "$PY" extract.py "runs/$job/$job.dat" "results/$job.csv" --press "results/${job}_press.csv" || true
    if [[ $job == flat_linear ]]; then
        {
            echo "one run of run.sh, $(date -u +%FT%TZ), OMP_NUM_THREADS=1, same case and mesh (flat, coarse: 1183 nodes, 864 hexes; press 0.5 mm, slide 3 mm in 0.1 mm steps)"
            echo "haptex simulate (CLI, whole process): $(printf '%.2f' "$hwall") s"
            echo "ccx flat_linear (whole process):      $(printf '%.2f' "$wall") s (rc=$rc)"
            echo "ratio ccx / haptex:                    $(echo "scale=1; $wall / $hwall" | bc)"
            echo "machine: $(lscpu | sed -n 's/^Model name: *//p'); L1d $(lscpu | sed -n 's/^L1d cache: *//p'), L2 $(lscpu | sed -n 's/^L2 cache: *//p'), L3 $(lscpu | sed -n 's/^L3 cache: *//p')"
        } | tee results/timing.txt
    fi
done

echo "== comparison"
"$PY" compare.py --results results
