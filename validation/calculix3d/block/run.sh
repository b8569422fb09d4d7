#!/usr/bin/env bash
# CalculiX runs of the compressed block (README.md here): decks, ccx, results/block.csv.
#   validation/calculix3d/block/run.sh      all runs (about 10 minutes on one core)
# CCX: the solver (default ccx); scratch in runs/ (not for git).
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
CCX="${CCX:-ccx}"
export OMP_NUM_THREADS=1 CCX_NPROC_EQUATION_SOLVER=1 CCX_NPROC_STIFFNESS=1 CCX_NPROC_RESULTS=1
cd "$HERE"
mkdir -p runs results
: > runs/times.txt
for spec in "C3D20R 4" "C3D20R 8" "C3D20R 12" "C3D20R 16"; do
    set -- $spec
    for kin in nlgeom linear; do
        job=block_${kin}_$1_n$2
        python3 make_decks.py --n "$2" --etype "$1" --kin "$kin" -o "runs/$job.inp"
        start=$(date +%s.%N)
        (cd runs && "$CCX" -i "$job" > "$job.log" 2>&1)
        end=$(date +%s.%N)
        echo "$job $(python3 -c "print($end - $start)")" >> runs/times.txt
        echo "$job done"
    done
done
python3 extract.py runs runs/times.txt > results/block.csv
{
    echo "date: $(date -u +%Y-%m-%dT%H:%M:%SZ)"
    echo "ccx: $("$CCX" -v 2>&1 | grep -m1 -i version | sed 's/^ *//') (Debian package $(dpkg-query -W -f='${Package} ${Version}' calculix-ccx 2>/dev/null || echo '?'))"
    echo "machine: $(lscpu | grep -m1 'Model name' | sed 's/  */ /g')"
} > results/provenance.txt
cat results/block.csv
