"""A real single-node SLURM cluster for the tests: Debian's slurm-wlm 22.05 and munge, started in a
temporary folder as this process's children and stopped by their process ids.

One node (this host, its cores and most of its memory), one partition ``test``,
``proctrack/linuxproc`` and ``task/none`` (no cgroups inside a container), ``MpiDefault=pmix``, no accounting storage
(so ``sacct`` has nothing to say: the executor plugin must ask ``squeue``), ``MinJobAge`` long
enough that ``squeue`` still shows a finished job when the plugin polls. Its own munge socket
and ports. Needs root (daemons as SlurmUser root).

Inside a job the executor plugin's job step drops ``SLURM_CONF`` from the environment (it keeps
only the allocation's ids), so ``srun`` there reads the default ``/etc/slurm/slurm.conf``, as on
a real cluster: the cluster links that path to its own config while it runs and removes the link
at the end. Where a real configuration is already there, it refuses to start rather than touch it.
"""
from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

#: Debian packages that provide the daemons and the client commands.
#: libpmix-dev: slurm's mpi/pmix plugin loads libpmix.so, which only the -dev package links; with
#: it ``srun`` starts Debian's Open MPI ranks (MpiDefault=pmix, as on most sites).
PACKAGES = ("slurm-wlm", "munge", "libpmix-dev")
#: Where SLURM's commands look for the configuration when SLURM_CONF is unset.
DEFAULT_CONF = Path("/etc/slurm/slurm.conf")
#: Seconds SLURM keeps a finished job visible to squeue: longer than the whole test, so that the
#: plugin always finds its jobs and the test can count them at the end.
MIN_JOB_AGE = 3600


class ClusterError(RuntimeError):
    """SLURM could not be installed or started here; the message says why."""


@dataclass
class Cluster:
    """A running local cluster: ``env`` points the SLURM commands at it."""

    folder: Path
    env: dict[str, str]
    partition: str = "test"
    pids: dict[str, int] = field(default_factory=dict)

    def log(self, daemon: str) -> str:
        path = self.folder / f"{daemon}.log"
        return path.read_text(errors="replace") if path.exists() else ""

    def run(self, *cmd: str, check: bool = True) -> subprocess.CompletedProcess:
        return subprocess.run(list(cmd), env=self.env, capture_output=True, text=True, check=check, timeout=60)


def install() -> None:
    """Install the packages when a daemon is missing (as scripts/install.sh does for LIGGGHTS)."""
    if all(shutil.which(b) for b in ("slurmctld", "slurmd", "sbatch", "squeue", "munged")) and _pmix_linked():
        return
    if os.geteuid() != 0:
        raise ClusterError("SLURM is not installed and installing it needs root (apt-get install slurm-wlm munge)")
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    for cmd in (["apt-get", "update", "-qq"], ["apt-get", "install", "-y", "-qq", "--no-install-recommends", *PACKAGES]):
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
        if proc.returncode != 0:
            raise ClusterError(f"{' '.join(cmd)} failed (exit {proc.returncode}): {proc.stderr[-2000:]}")


def _pmix_linked() -> bool:
    return any(Path(d).glob("libpmix.so") for d in ("/usr/lib/x86_64-linux-gnu", "/usr/lib/aarch64-linux-gnu", "/usr/lib"))


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def slurm_conf(folder: Path, host: str, cpus: int, memory_mb: int, munge_socket: Path) -> str:
    """The cluster's slurm.conf."""
    ctld_port, d_port = _free_port(), _free_port()
    return "\n".join([
        "ClusterName=granular-validate-test",
        f"SlurmctldHost={host}",
        "SlurmUser=root", "SlurmdUser=root",
        "AuthType=auth/munge", "CredType=cred/munge", f"AuthInfo=socket={munge_socket}",
        f"SlurmctldPort={ctld_port}", f"SlurmdPort={d_port}",
        f"StateSaveLocation={folder / 'state'}", f"SlurmdSpoolDir={folder / 'spool'}",
        f"SlurmctldPidFile={folder / 'slurmctld.pid'}", f"SlurmdPidFile={folder / 'slurmd.pid'}",
        f"SlurmctldLogFile={folder / 'slurmctld.log'}", f"SlurmdLogFile={folder / 'slurmd.log'}",
        "SlurmctldDebug=info", "SlurmdDebug=info",
        "ProctrackType=proctrack/linuxproc", "TaskPlugin=task/none",
        "SchedulerType=sched/backfill", "SelectType=select/cons_tres", "SelectTypeParameters=CR_Core_Memory",
        "AccountingStorageType=accounting_storage/none", "JobAcctGatherType=jobacct_gather/none",
        "JobCompType=jobcomp/none", "MpiDefault=pmix", "ReturnToService=2",
        f"MinJobAge={MIN_JOB_AGE}", "KillWait=5", "InactiveLimit=0",
        f"NodeName={host} CPUs={cpus} RealMemory={memory_mb} State=UNKNOWN",
        f"PartitionName=test Nodes={host} Default=YES MaxTime=INFINITE State=UP",
        "",
    ])


def _memory_mb() -> int:
    for line in Path("/proc/meminfo").read_text().splitlines():
        if line.startswith("MemTotal:"):
            return int(line.split()[1]) // 1024
    raise ClusterError("/proc/meminfo has no MemTotal")


def _wait(predicate, timeout: float, what: str, cluster: Cluster | None = None) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return
        time.sleep(0.5)
    logs = "" if cluster is None else "\n".join(f"--- {d}.log\n{cluster.log(d)[-2000:]}" for d in ("munged", "slurmctld", "slurmd"))
    raise ClusterError(f"{what} within {timeout:g} s\n{logs}")


@contextmanager
def local_cluster(folder: Path) -> Iterator[Cluster]:
    """Start munged, slurmctld and slurmd in ``folder``; stop them by pid at the end, pass or fail."""
    install()
    if os.geteuid() != 0:
        raise ClusterError("the local SLURM cluster runs its daemons as root: run the test as root")
    key = Path("/etc/munge/munge.key")
    if not key.is_file():
        raise ClusterError(f"{key} is missing (the munge package creates it): reinstall munge")
    folder.mkdir(parents=True, exist_ok=True)
    for sub in ("state", "spool", "munge"):
        (folder / sub).mkdir(exist_ok=True)
    host = socket.gethostname().split(".")[0]
    munge_socket = folder / "munge" / "munge.socket"
    conf = folder / "slurm.conf"
    conf.write_text(slurm_conf(folder, host, os.cpu_count() or 1, int(0.8 * _memory_mb()), munge_socket))
    if DEFAULT_CONF.is_symlink() and not DEFAULT_CONF.exists():
        DEFAULT_CONF.unlink()  # left by a test that was killed
    if DEFAULT_CONF.exists() or DEFAULT_CONF.is_symlink():
        raise ClusterError(f"{DEFAULT_CONF} exists: a SLURM is configured on this machine; the test starts its own "
                           "cluster and needs that path for it (jobs' srun reads it): run the test elsewhere")
    env = dict(os.environ, SLURM_CONF=str(conf))
    cluster = Cluster(folder, env)
    procs: dict[str, subprocess.Popen] = {}
    DEFAULT_CONF.parent.mkdir(parents=True, exist_ok=True)
    DEFAULT_CONF.symlink_to(conf)
    try:
        procs["munged"] = subprocess.Popen(
            ["munged", "--foreground", "--force", f"--socket={munge_socket}", f"--key-file={key}",
             f"--pid-file={folder / 'munge' / 'munged.pid'}", f"--log-file={folder / 'munged.log'}",
             f"--seed-file={folder / 'munge' / 'munged.seed'}"],
            stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT, start_new_session=True)
        _wait(munge_socket.exists, 20, "munged did not open its socket", cluster)
        for daemon, extra in (("slurmctld", ["-i"]), ("slurmd", ["-N", host])):
            with (folder / f"{daemon}.out").open("w") as out:
                procs[daemon] = subprocess.Popen([daemon, "-D", "-f", str(conf), *extra], env=env, stdout=out,
                                                 stderr=subprocess.STDOUT, start_new_session=True)
        cluster.pids = {name: p.pid for name, p in procs.items()}

        def node_idle() -> bool:
            for name, p in procs.items():
                if p.poll() is not None:
                    raise ClusterError(f"{name} exited with {p.returncode}: {(folder / f'{name}.out').read_text()[-2000:] if (folder / f'{name}.out').exists() else ''}\n{cluster.log(name)[-2000:]}")
            proc = cluster.run("sinfo", "-h", "-N", "-o", "%t", check=False)
            return proc.returncode == 0 and proc.stdout.strip() in ("idle", "mix", "alloc")

        _wait(node_idle, 60, "the node did not come up idle in sinfo", cluster)
        yield cluster
    finally:
        for name in ("slurmd", "slurmctld", "munged"):
            p = procs.get(name)
            if p is None or p.poll() is not None:
                continue
            os.killpg(p.pid, signal.SIGTERM)
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()
        if DEFAULT_CONF.is_symlink() and os.readlink(DEFAULT_CONF) == str(conf):
            DEFAULT_CONF.unlink()
