//! `--features mpi`: the MPI world as the library's [`bezchain::team::Team`] (every rank runs
//! the command in lockstep and shares the population batches, docs/ARCHITECTURE.md §4.3),
//! and the shell's side of it: only rank 0 prints (the others' standard output and error go to
//! `/dev/null`) and writes files ([`super::output::Outputs`]).

use bezchain::team::{self, Failure, Team};
use mpi::collective::Root;
use mpi::point_to_point::{Destination, Source};
use mpi::topology::{Communicator, SimpleCommunicator};
use std::io::Write;

/// The world communicator (a handle, fetched again on every call: MPI keeps the state).
struct World;

impl World {
    fn comm() -> SimpleCommunicator {
        SimpleCommunicator::world()
    }
}

impl Team for World {
    fn rank(&self) -> usize {
        Self::comm().rank() as usize
    }
    fn size(&self) -> usize {
        Self::comm().size() as usize
    }
    fn broadcast(&self, bytes: &mut Vec<u8>) {
        let world = Self::comm();
        let root = world.process_at_rank(0);
        let mut len = bytes.len() as u64;
        root.broadcast_into(&mut len);
        bytes.resize(len as usize, 0);
        if len > 0 {
            root.broadcast_into(&mut bytes[..]);
        }
    }
    fn gather(&self, bytes: &[u8]) -> Vec<Vec<u8>> {
        let world = Self::comm();
        if world.rank() != 0 {
            world.process_at_rank(0).send(bytes);
            return Vec::new();
        }
        let mut all = vec![bytes.to_vec()];
        for r in 1..world.size() {
            all.push(world.process_at_rank(r).receive_vec::<u8>().0);
        }
        all
    }
    fn abort(&self, code: i32) -> ! {
        Self::comm().abort(code)
    }
}

/// The file descriptor of the original standard error of a muted rank, for the one line it
/// may have to say itself ([`fail_alone`]).
static STDERR: std::sync::OnceLock<i32> = std::sync::OnceLock::new();

/// Initialise MPI (when launched by `mpirun` or `srun`, or alone as one rank), join the
/// library's team, and mute every rank but 0. Keep the universe until the end of `main`:
/// dropping it finalises MPI.
pub fn start() -> Option<mpi::environment::Universe> {
    let universe = mpi::initialize()?;
    // Only fails when called twice; `main` calls it once.
    let _ = team::join(Box::new(World));
    if team::rank() != 0 {
        mute();
    }
    Some(universe)
}

/// Send this process's standard output and error to `/dev/null`, keeping a copy of standard
/// error.
fn mute() {
    // SAFETY: plain descriptor calls on descriptors this process owns; nothing else is using
    // them yet (this runs first thing in `main`).
    unsafe {
        let null = libc::open(c"/dev/null".as_ptr(), libc::O_WRONLY);
        if null < 0 {
            return;
        }
        let saved = libc::dup(2);
        if saved >= 0 {
            let _ = STDERR.set(saved);
        }
        libc::dup2(null, 1);
        libc::dup2(null, 2);
        libc::close(null);
    }
}

/// A failure of this rank alone after the ranks agreed (the others may be waiting in a
/// collective): rank 0 prints it; another rank waits for a moment (rank 0, failing the same
/// way, ends the run first and says it) and then says it itself, on its saved standard error;
/// either then ends every rank ([`team::abort`]).
pub fn fail_alone(f: &Failure) -> ! {
    if team::is_root() {
        eprintln!("error: {}", f.message);
    } else {
        std::thread::sleep(std::time::Duration::from_secs(2));
        if let Some(&fd) = STDERR.get() {
            let line = format!("error: rank {}: {}\n", team::rank(), f.message);
            // SAFETY: `fd` is the duplicate of standard error made by `mute`, still open.
            unsafe {
                libc::write(fd, line.as_ptr().cast(), line.len());
            }
        }
    }
    let _ = std::io::stderr().flush();
    team::abort(f.status)
}
