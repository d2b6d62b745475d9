//! `cgv encode --manifest JOBS.json`: many motions, one process. Each job
//! is a `cgv encode` command line (input, output, options), parsed by the
//! same code as a single encode. A job is done when its output reads as a
//! whole `.cgv` file and the sidecar `OUTPUT.cgv.job` beside it records the
//! same command line; done jobs are skipped, so a run that stopped (or a
//! machine that failed) is resumed by running it again. Outputs are
//! written atomically (a temporary file renamed), so an output is never
//! half a file. The encoder is deterministic: the same job gives the same
//! bytes, which is what lets many machines share one manifest's outputs.

use anyhow::{bail, Context, Result};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// One entry of the manifest.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Job {
    input: String,
    output: PathBuf,
    #[serde(default)]
    args: Vec<String>,
}

/// The manifest of `cgv encode --manifest FILE` (or `--manifest=FILE`), if
/// that is the command.
pub fn requested(argv: &[String]) -> Option<PathBuf> {
    if argv.get(1).map(String::as_str) != Some("encode") {
        return None;
    }
    let mut it = argv.iter().skip(2);
    while let Some(a) = it.next() {
        if a == "--manifest" {
            return it.next().map(PathBuf::from);
        }
        if let Some(p) = a.strip_prefix("--manifest=") {
            return Some(PathBuf::from(p));
        }
    }
    None
}

/// The options given on the command line besides `--manifest FILE`: they
/// apply to every job, before the job's own.
fn shared_options(argv: &[String]) -> Vec<String> {
    let rest = argv.iter().skip_while(|a| a.as_str() != "encode").skip(1);
    let mut out = Vec::new();
    let mut skip = false;
    for a in rest {
        if std::mem::take(&mut skip) {
            continue;
        }
        match a.as_str() {
            "--manifest" => skip = true,
            _ if a.starts_with("--manifest=") => {}
            _ => out.push(a.clone()),
        }
    }
    out
}

fn sidecar(output: &Path) -> PathBuf {
    let mut s = output.as_os_str().to_owned();
    s.push(".job");
    PathBuf::from(s)
}

/// Whether `output` is a whole `.cgv` file made by exactly this job.
fn is_done(output: &Path, command: &str) -> bool {
    let same = std::fs::read_to_string(sidecar(output)).is_ok_and(|s| s == command);
    same && std::fs::read(output).is_ok_and(|b| cgv::format::read(&b).is_ok())
}

/// Runs every job of the manifest at `path`; `argv` is this process's command line.
pub fn run(path: &Path, argv: &[String]) -> Result<()> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("{}: cannot read the manifest", path.display()))?;
    let jobs: Vec<Job> = serde_json::from_str(&text).with_context(|| {
        format!("{}: not a manifest (a JSON list of {{\"input\", \"output\", \"args\"}})", path.display())
    })?;
    // Relative paths in the manifest are relative to the manifest's folder.
    let base = path.parent().unwrap_or(Path::new(""));
    let shared = shared_options(argv);
    let (mut done, mut skipped, mut failed) = (0, 0, Vec::new());
    for (k, job) in jobs.iter().enumerate() {
        let input = if job.input.starts_with("builtin:") {
            job.input.clone()
        } else {
            base.join(&job.input).display().to_string()
        };
        let output = base.join(&job.output);
        let mut line = vec!["encode".to_string(), input, "-o".into(), output.display().to_string()];
        line.extend(shared.iter().cloned());
        line.extend(job.args.iter().cloned());
        let command = serde_json::to_string(&line)?;
        let tag = format!("[{}/{}] {}", k + 1, jobs.len(), output.display());
        if is_done(&output, &command) {
            println!("{tag}: done before, skipped");
            skipped += 1;
            continue;
        }
        println!("{tag}: encoding {}", line[1]);
        let result = super::encode::run_job(&line);
        match result.and_then(|()| cgv::output::write_atomic(&sidecar(&output), command.as_bytes()).map_err(Into::into))
        {
            Ok(()) => done += 1,
            Err(e) => {
                eprintln!("{tag}: failed: {}", super::error_text(&e));
                failed.push(output.display().to_string());
            }
        }
    }
    println!("{} jobs: {done} encoded, {skipped} skipped (done before), {} failed", jobs.len(), failed.len());
    if !failed.is_empty() {
        bail!("{} of {} jobs failed: {}", failed.len(), jobs.len(), failed.join(", "));
    }
    Ok(())
}
