//! Job files for running a study's shards on a cluster (`waggle study FILE --slurm` or
//! `--kubernetes`): the study as run (`study.toml`), then either a Slurm array script, the merge
//! as a job depending on the array, and `submit.sh` chaining them; or a Kubernetes Indexed Job
//! and its merge Job. Every shard writes `DIR/shard-K-of-N/` (resumable: a requeued task runs
//! only its missing trials); the merge writes `DIR/merged/`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use crate::harness::runs::records::write_atomic;

/// Resources and placement of the array's tasks.
#[derive(Debug, Clone)]
pub struct ClusterJob {
    /// The study's name (job names).
    pub name: String,
    /// The study as run: written to `DIR/study.toml`, which every shard reads.
    pub study_toml: String,
    /// Shards (array tasks, or the Indexed Job's completions).
    pub shards: u64,
    pub partition: Option<String>,
    /// Slurm time limit per task (`HH:MM:SS`, `D-HH`, minutes…).
    pub time: String,
    /// Memory per task (`8G`).
    pub mem: String,
    pub cpus_per_task: u32,
    /// The waggle binary the tasks run (a path every node sees).
    pub waggle: PathBuf,
    /// Extra arguments for every shard (`--render full`).
    pub extra: Vec<String>,
}

/// `DIR/shard-K-of-N`.
pub fn shard_dir(out: &Path, k: u64, n: u64) -> PathBuf {
    out.join(format!("shard-{k}-of-{n}"))
}

fn quote(s: &str) -> String {
    if !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-+=:,@%".contains(c))
    {
        s.to_owned()
    } else {
        format!("'{}'", s.replace('\'', r"'\''"))
    }
}

impl ClusterJob {
    fn shard_args(&self, out: &Path) -> String {
        let mut s = format!(
            "study {} --shard-from-env --jobs {}",
            quote(&out.join("study.toml").to_string_lossy()),
            self.cpus_per_task
        );
        for a in &self.extra {
            s.push(' ');
            s.push_str(&quote(a));
        }
        s
    }

    fn merge_args(&self, out: &Path) -> String {
        let mut s = String::from("study merge");
        for k in 1..=self.shards {
            let _ = write!(
                s,
                " {}",
                quote(&shard_dir(out, k, self.shards).to_string_lossy())
            );
        }
        let _ = write!(s, " --out {}", quote(&out.join("merged").to_string_lossy()));
        s
    }

    fn header(&self, out: &Path, job: &str, log: &str) -> String {
        let mut s = format!(
            "#!/bin/bash\n#SBATCH --job-name={}\n#SBATCH --output={}\n",
            quote(job),
            quote(&out.join("slurm").join(log).to_string_lossy())
        );
        if let Some(p) = &self.partition {
            let _ = writeln!(s, "#SBATCH --partition={}", quote(p));
        }
        let _ = writeln!(s, "#SBATCH --time={}", quote(&self.time));
        let _ = writeln!(s, "#SBATCH --mem={}", quote(&self.mem));
        s
    }

    /// Writes `DIR/study.toml` and `DIR/slurm/{array.sbatch,merge.sbatch,submit.sh}`; returns
    /// the path of `submit.sh`.
    pub fn write_slurm(&self, out: &Path) -> Result<PathBuf> {
        let out = std::path::absolute(out).context("the output directory's absolute path")?;
        write_atomic(&out.join("study.toml"), self.study_toml.as_bytes())?;
        let n = self.shards;
        let waggle = quote(&self.waggle.to_string_lossy());
        let mut array = self.header(&out, &format!("waggle-{}", self.name), "shard-%a.log");
        let _ = write!(
            array,
            "#SBATCH --array=0-{}\n#SBATCH --cpus-per-task={}\n#SBATCH --requeue\n\
             # Shard K of N runs trials K of N (resumable: a requeued or rerun task runs only its\n\
             # missing trials). waggle reads SLURM_ARRAY_TASK_ID/MIN/COUNT itself.\n\
             set -euo pipefail\n\
             k=$((SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN + 1))\n\
             exec {waggle} {} --out {}/shard-${{k}}-of-{n}\n",
            n - 1,
            self.cpus_per_task,
            self.shard_args(&out),
            quote(&out.to_string_lossy()),
        );
        let mut merge = self.header(&out, &format!("waggle-{}-merge", self.name), "merge.log");
        let _ = write!(
            merge,
            "#SBATCH --cpus-per-task=1\nset -euo pipefail\nexec {waggle} {}\n",
            self.merge_args(&out)
        );
        let slurm = out.join("slurm");
        write_atomic(&slurm.join("array.sbatch"), array.as_bytes())?;
        write_atomic(&slurm.join("merge.sbatch"), merge.as_bytes())?;
        let submit = format!(
            "#!/bin/bash\n# Submits the shards as one job array and the merge as a job that \
             starts once every task succeeded.\nset -euo pipefail\ncd {dir}\n\
             array=$(sbatch --parsable array.sbatch)\narray=${{array%%;*}}\n\
             merge=$(sbatch --parsable --dependency=afterok:$array merge.sbatch)\n\
             merge=${{merge%%;*}}\n\
             echo \"array job $array ({n} tasks), merge job $merge -> {merged}\"\n",
            dir = quote(&slurm.to_string_lossy()),
            merged = out.join("merged").display()
        );
        let path = slurm.join("submit.sh");
        write_atomic(&path, submit.as_bytes())?;
        Ok(path)
    }

    /// Writes `DIR/study.toml` and `DIR/kubernetes/{study-job.yaml,merge-job.yaml}`: an Indexed
    /// Job of N completions running image `image`, `DIR` being the path of a volume every pod
    /// mounts (claim `claim`, ReadWriteMany), and the merge Job to apply once it completes.
    pub fn write_kubernetes(&self, out: &Path, image: &str, claim: &str) -> Result<PathBuf> {
        let out = std::path::absolute(out).context("the output directory's absolute path")?;
        write_atomic(&out.join("study.toml"), self.study_toml.as_bytes())?;
        let n = self.shards;
        let name = format!("waggle-{}", self.name.replace(['_', '.'], "-")).to_lowercase();
        let dir = out.to_string_lossy();
        let volume = |indent: &str| {
            format!("{indent}volumeMounts:\n{indent}  - {{name: studies, mountPath: {dir}}}\n")
        };
        let pod_end = format!(
            "      volumes:\n        - name: studies\n          persistentVolumeClaim: {{claimName: {claim}}}\n"
        );
        let study = format!(
            "# waggle study {name}: {n} shards as a Kubernetes Indexed Job (JOB_COMPLETION_INDEX\n\
             # 0..{last}); a retried pod resumes its shard. Then: kubectl wait --for=condition=complete\n\
             # job/{name} --timeout=24h && kubectl apply -f merge-job.yaml\n\
             apiVersion: batch/v1\nkind: Job\nmetadata:\n  name: {name}\nspec:\n  \
             completionMode: Indexed\n  completions: {n}\n  parallelism: {n}\n  backoffLimit: {retries}\n  \
             template:\n    spec:\n      restartPolicy: Never\n      containers:\n        - name: shard\n          \
             image: {image}\n          command: [\"sh\", \"-c\"]\n          args:\n            - >-\n              \
             exec waggle {args} --shard-count {n}\n              --out {dir}/shard-$((JOB_COMPLETION_INDEX + 1))-of-{n}\n          \
             resources:\n            requests: {{cpu: \"{cpus}\", memory: {mem}}}\n            limits: {{memory: {mem}}}\n{vol}{pod_end}",
            last = n - 1,
            retries = 3 * n,
            args = self.shard_args(&out),
            cpus = self.cpus_per_task,
            mem = k8s_memory(&self.mem),
            vol = volume("          "),
        );
        let merge = format!(
            "# The merge of {name}'s shards: apply once job/{name} is complete.\n\
             apiVersion: batch/v1\nkind: Job\nmetadata:\n  name: {name}-merge\nspec:\n  backoffLimit: 2\n  \
             template:\n    spec:\n      restartPolicy: Never\n      containers:\n        - name: merge\n          \
             image: {image}\n          command: [\"sh\", \"-c\"]\n          args: [\"exec waggle {args}\"]\n{vol}{pod_end}",
            args = self.merge_args(&out).replace('\'', ""),
            vol = volume("          "),
        );
        let k8s = out.join("kubernetes");
        write_atomic(&k8s.join("study-job.yaml"), study.as_bytes())?;
        let path = k8s.join("merge-job.yaml");
        write_atomic(&path, merge.as_bytes())?;
        Ok(k8s.join("study-job.yaml"))
    }
}

/// Slurm's `8G` as Kubernetes' `8Gi`.
fn k8s_memory(mem: &str) -> String {
    match mem.strip_suffix(['G', 'M', 'K', 'T']) {
        Some(num) => format!("{num}{}i", &mem[num.len()..]),
        None => mem.to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_slurm_files_chain_the_merge_after_the_array() {
        let dir = std::env::temp_dir().join(format!("waggle-cluster-{}", std::process::id()));
        let job = ClusterJob {
            name: "tiny".into(),
            study_toml: "name = \"tiny\"\n".into(),
            shards: 4,
            partition: Some("debug".into()),
            time: "00:30:00".into(),
            mem: "2G".into(),
            cpus_per_task: 2,
            waggle: "/opt/waggle/bin/waggle".into(),
            extra: vec![],
        };
        let submit = job.write_slurm(&dir).unwrap();
        let array = std::fs::read_to_string(dir.join("slurm/array.sbatch")).unwrap();
        for needle in [
            "#SBATCH --array=0-3",
            "#SBATCH --partition=debug",
            "#SBATCH --time=00:30:00",
            "#SBATCH --mem=2G",
            "#SBATCH --cpus-per-task=2",
            "--shard-from-env --jobs 2",
            "/shard-${k}-of-4",
        ] {
            assert!(array.contains(needle), "{needle} not in {array}");
        }
        let merge = std::fs::read_to_string(dir.join("slurm/merge.sbatch")).unwrap();
        assert!(merge.contains("shard-4-of-4 --out"), "{merge}");
        let submit = std::fs::read_to_string(submit).unwrap();
        assert!(submit.contains("--dependency=afterok:$array"), "{submit}");
        job.write_kubernetes(&dir, "waggle:1", "studies").unwrap();
        let k8s = std::fs::read_to_string(dir.join("kubernetes/study-job.yaml")).unwrap();
        assert!(
            k8s.contains("completionMode: Indexed") && k8s.contains("memory: 2Gi"),
            "{k8s}"
        );
        assert!(k8s.contains("--shard-count 4"), "{k8s}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
