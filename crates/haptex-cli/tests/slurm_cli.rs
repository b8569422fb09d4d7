//! `haptex db build` as a Slurm job array on a real cluster: a single-node
//! cluster (Debian's munge, slurmctld and slurmd, started by
//! scripts/slurm-cluster.sh in a temporary directory) runs a reduced sweep
//! as `sbatch --array=1-4`, each task computing its shard from the
//! SLURM_ARRAY_* variables Slurm sets, into one shared scratch directory;
//! `haptex db merge` joins them, and the result is compared with a local
//! build of the same sweep: the model matrices and run profiles byte for
//! byte, metadata.json but for the times it records. Then `haptex db
//! refine` of the merged database runs as one array per round (each task
//! its shard of the round, `--plan` counting what a round still lacks)
//! and one refinement that writes, against a refinement on this machine:
//! the same bytes again (docs/database.md, "on a cluster").
//!
//! Needs root and the Debian packages munge, slurmctld, slurmd and
//! slurm-client (scripts/test.sh installs them as root). Where the cluster
//! cannot start, the test says why on the terminal and is skipped;
//! HAPTEX_SLURM_TEST=require makes that a failure instead (for a machine
//! that must run it), HAPTEX_SLURM_TEST=skip skips it without trying.

use std::io::{BufRead, BufReader, Write};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The sweep: 3 templates x 2 widths x 2 heights x 2 velocities = 24 runs of
/// the default mesh (about 3 s of FE time on 2 cores).
const SWEEP: [&str; 8] =
    ["--templates", "bump,edge,sine", "--widths", "1,2", "--heights", "0.2,0.3", "--velocities", "20,50"];
const RUNS: usize = 24;
/// Array tasks: more than the node's CPUs, so that tasks also queue.
const TASKS: usize = 4;
/// The refinement of the sine along r_w: each round adds a width with a
/// run per height and velocity (4, one per task), and the budget allows
/// two rounds (the third would pass it; measured: the estimate at the new
/// widths 1.5 and 1.25 mm was off by about 30% of the range, so the
/// target stops none of them).
const REFINE: [&str; 6] = ["--template", "sine", "--budget", "9", "--jobs", "1"];
const REFINE_ROUND_RUNS: usize = 4;
const REFINE_ROUNDS: usize = 2;
/// The longest the job may take, queueing included.
const JOB_TIMEOUT: Duration = Duration::from_secs(120);

#[test]
fn slurm_job_array_builds_the_same_database_as_a_local_build() {
    let mode = std::env::var("HAPTEX_SLURM_TEST").unwrap_or_default();
    if mode == "skip" {
        skipped("HAPTEX_SLURM_TEST=skip");
        return;
    }
    // A short path: munge's socket lives in the cluster's directory.
    let tmp = tempfile::Builder::new().prefix("haptex-slurm-").tempdir_in("/tmp").unwrap();
    let started = Instant::now();
    let cluster = match Cluster::start(tmp.path()) {
        Ok(cluster) => cluster,
        Err(reason) => {
            assert!(mode != "require", "HAPTEX_SLURM_TEST=require, but the Slurm cluster did not start:\n{reason}");
            skipped(&format!("the Slurm cluster did not start:\n{reason}"));
            return;
        }
    };
    let t_cluster = started.elapsed();

    // The job script, as docs/database.md shows it.
    let scratch = tmp.path().join("scratch");
    std::fs::create_dir(&scratch).unwrap();
    let script = tmp.path().join("build-db.sbatch");
    std::fs::write(&script, job_script()).unwrap();

    let submitted = Instant::now();
    let job = run_array(&cluster, &script, &scratch, tmp.path());
    let t_job = submitted.elapsed();

    // Each task computed its own shard, found from Slurm's variables.
    for k in 1..=TASKS {
        let log = read(&tmp.path().join(format!("haptex-db-{job}_{k}.log")));
        let want = format!("shard {k}/{TASKS}: {} of {RUNS} runs", RUNS / TASKS);
        assert!(log.contains(&want), "task {k}'s log does not say '{want}':\n{log}");
        assert!(log.contains(&format!("{} runs computed (0 were already done)", RUNS / TASKS)), "task {k}:\n{log}");
    }
    let db = scratch.join("haptex-db");
    assert_eq!(count_csv(&db.join("runs")), RUNS, "runs in the shared scratch directory");
    assert!(!db.join("metadata.json").exists(), "a task wrote the database: shards only compute runs");

    let merging = Instant::now();
    let merged = tmp.path().join("merged");
    let out = haptex(&["db", "merge", "--from", path(&db), "--out", path(&merged)]);
    assert!(out.status.success(), "db merge: {}", text(&out.stderr));
    let t_merge = merging.elapsed();

    // The refinement: one array per round on the cluster, against one
    // refinement here, both from copies of the merged database.
    let refining = Instant::now();
    let shared = scratch.join("refined");
    copy_database(&merged, &shared);
    let local_refined = tmp.path().join("refined-local");
    copy_database(&merged, &local_refined);
    let refine_script = tmp.path().join("refine-db.sbatch");
    std::fs::write(&refine_script, refine_job_script()).unwrap();
    let mut arrays = 0;
    loop {
        let mut args = vec!["db", "refine", "--db", path(&shared), "--plan"];
        args.extend_from_slice(&REFINE);
        let out = haptex(&args);
        assert!(out.status.success(), "db refine --plan: {}", text(&out.stderr));
        let pending: usize = text(&out.stdout)
            .trim()
            .parse()
            .unwrap_or_else(|_| panic!("--plan printed '{}', not a number of runs", text(&out.stdout)));
        if pending == 0 {
            break;
        }
        assert_eq!(pending, REFINE_ROUND_RUNS, "a round adds a run per height and velocity");
        assert!(arrays < REFINE_ROUNDS, "more rounds than the budget allows");
        let job = run_array(&cluster, &refine_script, &scratch, tmp.path());
        arrays += 1;
        for k in 1..=TASKS {
            let log = read(&tmp.path().join(format!("haptex-refine-{job}_{k}.log")));
            // The round's 4 runs over 4 tasks: one each.
            let want = format!("round {arrays}: 1 runs of shard {k}/{TASKS} computed");
            assert!(log.contains(&want), "refine task {k} of round {arrays} does not say '{want}':\n{log}");
        }
        assert_eq!(
            metadata_without_times(&shared),
            metadata_without_times(&merged),
            "an array task wrote the database: shards only compute runs"
        );
    }
    assert_eq!(arrays, REFINE_ROUNDS, "one array per round until --plan printed 0");
    let mut args = vec!["db", "refine", "--db", path(&shared), "-q"];
    args.extend_from_slice(&REFINE);
    let out = haptex(&args);
    assert!(out.status.success(), "db refine (writing): {}", text(&out.stderr));
    let added = REFINE_ROUNDS * REFINE_ROUND_RUNS;
    assert!(
        text(&out.stdout).starts_with(&format!("{added} runs added in {REFINE_ROUNDS} rounds; stopped:")),
        "{}",
        text(&out.stdout)
    );
    let t_refine = refining.elapsed();

    let stopping = Instant::now();
    cluster.stop();
    let t_stop = stopping.elapsed();

    let mut args = vec!["db", "refine", "--db", path(&local_refined), "-q"];
    args.extend_from_slice(&REFINE);
    let out = haptex(&args);
    assert!(out.status.success(), "local db refine: {}", text(&out.stderr));
    let file = "sine.csv";
    let (a, b) = (read(&local_refined.join(file)), read(&shared.join(file)));
    assert_eq!(a.lines().filter(|l| !l.starts_with('#')).count(), 1 + RUNS / 3 + added, "{file}: rows");
    assert!(a == b, "{file}: the refinement on the cluster differs from the local one");
    for other in ["bump.csv", "edge.csv"] {
        assert!(read(&shared.join(other)) == read(&merged.join(other)), "{other} changed");
    }
    assert_eq!(
        metadata_without_times(&local_refined),
        metadata_without_times(&shared),
        "the refined metadata.json (but for created, cpu_time_s, build_wall_time_s)"
    );

    let local_started = Instant::now();
    let local = tmp.path().join("local");
    let mut args = vec!["db", "build", "--out", path(&local), "--jobs", "2", "-q"];
    args.extend_from_slice(&SWEEP);
    let out = haptex(&args);
    assert!(out.status.success(), "local db build: {}", text(&out.stderr));
    let t_local = local_started.elapsed();

    assert_same_database(&local, &merged);
    eprintln!(
        "slurm: cluster up in {:.1} s, {TASKS}-task array of {RUNS} runs done in {:.1} s (submit to empty queue), \
         merge {:.1} s, refinement in {REFINE_ROUNDS} arrays {:.1} s, cluster stopped in {:.1} s; local build {:.1} \
         s; whole test {:.1} s",
        t_cluster.as_secs_f64(),
        t_job.as_secs_f64(),
        t_merge.as_secs_f64(),
        t_refine.as_secs_f64(),
        t_stop.as_secs_f64(),
        t_local.as_secs_f64(),
        started.elapsed().as_secs_f64()
    );
}

/// The array job: `haptex db build` reads its shard from Slurm's variables.
fn job_script() -> String {
    array_script("haptex-db", &format!("haptex db build --out \"$SCRATCH/haptex-db\" --jobs 1 {}", SWEEP.join(" ")))
}

/// The array job of one round of `haptex db refine`: each task computes
/// its shard of the round, found from Slurm's variables.
fn refine_job_script() -> String {
    array_script("haptex-refine", &format!("haptex db refine --db \"$SCRATCH/refined\" {}", REFINE.join(" ")))
}

/// A job array of TASKS one-CPU tasks named `name` (each logging to
/// `name-JOB_TASK.log`) running `command`.
fn array_script(name: &str, command: &str) -> String {
    format!(
        "#!/bin/bash\n\
         #SBATCH --job-name={name}\n\
         #SBATCH --array=1-{TASKS}\n\
         #SBATCH --cpus-per-task=1\n\
         #SBATCH --time=00:10:00\n\
         #SBATCH --output={name}-%A_%a.log\n\
         set -euo pipefail\n\
         {command}\n"
    )
}

/// Submits `script` (from `dir`, where the tasks' logs go, with SCRATCH
/// set), waits for every task to leave the queue and checks that each
/// completed with exit code 0; the job's id.
fn run_array(cluster: &Cluster, script: &Path, scratch: &Path, dir: &Path) -> String {
    let submitted = Instant::now();
    let out = cluster
        .client("sbatch")
        .arg("--parsable")
        .arg(script)
        .env("SCRATCH", scratch)
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "sbatch failed: {}", text(&out.stderr));
    let job = text(&out.stdout).trim().split(';').next().unwrap().to_string();
    assert!(job.parse::<u64>().is_ok(), "sbatch --parsable printed '{job}', not a job id");
    loop {
        let out = cluster.client("squeue").args(["-h", "-j", &job, "-o", "%i %T %R"]).output().unwrap();
        assert!(out.status.success(), "squeue failed: {}", text(&out.stderr));
        if text(&out.stdout).trim().is_empty() {
            break;
        }
        assert!(
            submitted.elapsed() < JOB_TIMEOUT,
            "job {job} not finished after {JOB_TIMEOUT:?}; squeue:\n{}\n{}",
            text(&out.stdout),
            logs(dir)
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    // Each task's state and exit code, from slurmctld (no accounting
    // database here, so no sacct).
    let out = cluster.client("scontrol").args(["-o", "show", "job", &job]).output().unwrap();
    assert!(out.status.success(), "scontrol failed: {}", text(&out.stderr));
    let records = text(&out.stdout);
    let mut tasks: Vec<(usize, String, String)> = records
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let field = |name: &str| {
                l.split_whitespace()
                    .find_map(|f| f.strip_prefix(name))
                    .unwrap_or_else(|| panic!("no {name} in: {l}"))
                    .to_string()
            };
            (field("ArrayTaskId=").parse().unwrap(), field("JobState="), field("ExitCode="))
        })
        .collect();
    tasks.sort();
    let expected: Vec<_> = (1..=TASKS).map(|k| (k, "COMPLETED".to_string(), "0:0".to_string())).collect();
    assert_eq!(tasks, expected, "array tasks of job {job}:\n{records}\n{}", logs(dir));
    job
}

/// A database's metadata and model matrices (not its runs) copied to `to`.
fn copy_database(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap().flatten() {
        if entry.file_type().unwrap().is_file() {
            std::fs::copy(entry.path(), to.join(entry.file_name())).unwrap();
        }
    }
}

/// Says on the terminal, not only in the captured output, that the test
/// was skipped and why (libtest shows a skipped test as passed).
fn skipped(reason: &str) {
    let message = format!("\nSKIPPED slurm_job_array_builds_the_same_database_as_a_local_build: {reason}\n");
    // Written to the stderr handle, which the test harness does not capture.
    let _ = std::io::stderr().write_all(message.as_bytes());
}

/// The cluster of scripts/slurm-cluster.sh, stopped when dropped (its
/// script stops the daemons when its stdin closes).
struct Cluster {
    child: Child,
    stdin: Option<ChildStdin>,
    conf: PathBuf,
}

impl Cluster {
    /// Starts a cluster in DIR/cluster; Err(why) if it cannot run here.
    fn start(dir: &Path) -> Result<Cluster, String> {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts/slurm-cluster.sh");
        let log_path = dir.join("slurm-cluster.log");
        let log = std::fs::File::create(&log_path).unwrap();
        let (port, _) = free_port_pair();
        let mut command = Command::new("bash");
        command
            .arg(&script)
            .arg(dir.join("cluster"))
            .env("SLURM_CLUSTER_PORT", port.to_string())
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(log);
        let mut child = command.spawn().map_err(|e| format!("cannot run bash {}: {e}", script.display()))?;
        let stdin = child.stdin.take();
        let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
        let ready = lines.find_map(|line| line.ok()?.strip_prefix("ready SLURM_CONF=").map(PathBuf::from));
        match ready {
            Some(conf) => Ok(Cluster { child, stdin, conf }),
            None => {
                drop(stdin);
                let status = child.wait().unwrap();
                let log = std::fs::read_to_string(&log_path).unwrap_or_default();
                if status.code() == Some(77) {
                    Err(log)
                } else {
                    panic!("scripts/slurm-cluster.sh failed ({status}):\n{log}")
                }
            }
        }
    }

    /// A Slurm client command of this cluster, with no job variables of an
    /// enclosing Slurm job (sbatch also takes options from SBATCH_*), and
    /// haptex on the PATH for the job (sbatch passes its environment on).
    fn client(&self, program: &str) -> Command {
        let mut command = Command::new(program);
        for (name, _) in std::env::vars_os() {
            let name = name.to_string_lossy();
            if name.starts_with("SLURM_") || name.starts_with("SBATCH_") || name.starts_with("SQUEUE_") {
                command.env_remove(&*name);
            }
        }
        command.env_remove("HAPTEX_DB");
        let bin = Path::new(env!("CARGO_BIN_EXE_haptex")).parent().unwrap();
        let path = std::env::var_os("PATH").unwrap_or_default();
        let path =
            std::env::join_paths(std::iter::once(bin.to_path_buf()).chain(std::env::split_paths(&path))).unwrap();
        command.env("SLURM_CONF", &self.conf).env("PATH", path).stdin(Stdio::null());
        command
    }

    fn stop(mut self) {
        self.shutdown();
    }

    fn shutdown(&mut self) {
        if let Some(stdin) = self.stdin.take() {
            drop(stdin);
            let _ = self.child.wait();
        }
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// Two consecutive free TCP ports (slurmctld's and slurmd's).
fn free_port_pair() -> (u16, u16) {
    for _ in 0..100 {
        let first = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = first.local_addr().unwrap().port();
        if port < u16::MAX && TcpListener::bind(("127.0.0.1", port + 1)).is_ok() {
            return (port, port + 1);
        }
    }
    panic!("no two consecutive free ports");
}

fn haptex(args: &[&str]) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_haptex"));
    command.args(args).stdin(Stdio::null());
    for var in ["SLURM_ARRAY_TASK_ID", "SLURM_ARRAY_TASK_COUNT", "SLURM_ARRAY_TASK_MIN", "HAPTEX_DB"] {
        command.env_remove(var);
    }
    command.output().expect("run haptex")
}

fn path(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn count_csv(dir: &Path) -> usize {
    std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter(|e| e.as_ref().is_ok_and(|e| e.file_name().to_string_lossy().ends_with(".csv")))
        .count()
}

/// The tasks' logs and the daemons' logs, for a failure message.
fn logs(dir: &Path) -> String {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir).unwrap().flatten().map(|e| e.path()).collect();
    files.extend(["slurmctld.log", "slurmd.log"].map(|f| dir.join("cluster").join(f)));
    files.sort();
    let mut out = String::new();
    for file in files.iter().filter(|f| f.extension().is_some_and(|e| e == "log")) {
        let text = std::fs::read_to_string(file).unwrap_or_default();
        let tail: Vec<&str> = text.lines().rev().take(20).collect();
        out += &format!("--- {} (last lines)\n", file.display());
        for line in tail.iter().rev() {
            out += line;
            out += "\n";
        }
    }
    out
}

/// metadata.json without the fields that record when and how fast it was
/// built (docs/database.md: they change with every build).
fn metadata_without_times(dir: &Path) -> serde_json::Value {
    let mut value: serde_json::Value = serde_json::from_str(&read(&dir.join("metadata.json"))).unwrap();
    let object = value.as_object_mut().unwrap();
    for key in ["created", "cpu_time_s", "build_wall_time_s"] {
        object.remove(key);
    }
    value
}

/// A run file without its `# wall_time_s=` line (how long the run took).
fn run_without_time(path: &Path) -> String {
    read(path).lines().filter(|l| !l.starts_with("# wall_time_s=")).map(|l| format!("{l}\n")).collect()
}

fn assert_same_database(local: &Path, merged: &Path) {
    for template in ["bump", "edge", "sine"] {
        let file = format!("{template}.csv");
        let (a, b) = (std::fs::read(local.join(&file)).unwrap(), std::fs::read(merged.join(&file)).unwrap());
        assert_eq!(
            text(&a).lines().filter(|l| !l.starts_with('#')).count(),
            1 + RUNS / 3,
            "{file}: a header and a row per run"
        );
        assert!(a == b, "{file}: the Slurm build's model matrix differs from the local build's");
    }
    assert_eq!(
        metadata_without_times(local),
        metadata_without_times(merged),
        "metadata.json (but for created, cpu_time_s, build_wall_time_s)"
    );
    // The runs themselves: the local build's and the tasks' in the scratch
    // directory, which the merge read.
    let scratch_runs = merged.parent().unwrap().join("scratch/haptex-db/runs");
    let mut names: Vec<_> = std::fs::read_dir(local.join("runs"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .filter(|n| n.to_string_lossy().ends_with(".csv"))
        .collect();
    names.sort();
    assert_eq!(names.len(), RUNS);
    for name in names {
        let (a, b) = (local.join("runs").join(&name), scratch_runs.join(&name));
        assert!(run_without_time(&a) == run_without_time(&b), "{}: the run differs", name.to_string_lossy());
    }
    assert_eq!(read(&local.join("sweep.json")), read(&merged.parent().unwrap().join("scratch/haptex-db/sweep.json")));
}
