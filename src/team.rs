//! The processes a run is spread over (MPI ranks under `mpirun`, one process otherwise) and
//! the one way work is shared among them: [`share_rows`], rows of a batch split into
//! contiguous ranges, one per rank, whose per-row records are gathered and handed to every
//! rank (docs/ARCHITECTURE.md §4.3); [`share_records`] the same for records of any size.
//!
//! The library holds no MPI code: the binary built with `--features mpi` registers its
//! communicator as a [`Team`] ([`join`]); without one every call here is the one-process case.
//! Every rank runs the same command in lockstep; rank 0's inputs to a shared batch are
//! broadcast, so the rows every rank evaluates are rank 0's, and the records every rank gets
//! back are the same bytes. A row's record must depend only on the row (and state every rank
//! holds alike), not on the other rows of its range: then the records, and the run, are the
//! same for every number of ranks.

use crate::error::{Error, Result};
use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::OnceLock;
use std::thread::ThreadId;

/// The collective operations a run needs from its processes (an MPI communicator). Every
/// rank calls them in the same order; rank 0 is the root.
pub trait Team: Send + Sync {
    /// This process's rank, `0..size()`.
    fn rank(&self) -> usize;
    /// The number of processes.
    fn size(&self) -> usize;
    /// Replace `bytes` on every rank by rank 0's.
    fn broadcast(&self, bytes: &mut Vec<u8>);
    /// Every rank's `bytes`, in rank order, on rank 0 (empty on the others).
    fn gather(&self, bytes: &[u8]) -> Vec<Vec<u8>>;
    /// End every process of the run now, with exit status `code` (MPI_Abort).
    fn abort(&self, code: i32) -> !;
}

/// The registered team, the thread that may use it, and whether the ranks have agreed that
/// every one of them set up its run ([`agree`]).
struct Registered {
    team: Box<dyn Team>,
    thread: ThreadId,
    agreed: AtomicBool,
}

static TEAM: OnceLock<Registered> = OnceLock::new();

/// Set when a collective has handed every rank the same failure: the ranks end together,
/// each with that failure, without aborting.
static SHARED_FAILURE: AtomicBool = AtomicBool::new(false);

/// True when every rank has been handed the same failure by a collective ([`agree`],
/// [`share_rows`]): each can end normally with it (rank 0 saying it), none waits for another.
#[must_use]
pub fn failure_is_shared() -> bool {
    SHARED_FAILURE.load(Ordering::Relaxed)
}

/// Make `team` the processes of this run; collectives run on the calling thread only (work
/// shared from another thread, inside a parallel loop, runs whole on each rank). Once per
/// process; a second call is refused.
pub fn join(team: Box<dyn Team>) -> Result<()> {
    TEAM.set(Registered {
        team,
        thread: std::thread::current().id(),
        agreed: AtomicBool::new(false),
    })
    .map_err(|_| Error::invalid("the process has joined a team already"))
}

/// This process's rank (0 without a team).
#[must_use]
pub fn rank() -> usize {
    TEAM.get().map_or(0, |t| t.team.rank())
}

/// The number of processes (1 without a team).
#[must_use]
pub fn size() -> usize {
    TEAM.get().map_or(1, |t| t.team.size())
}

/// True on the rank that prints and writes files (rank 0, or the only process).
#[must_use]
pub fn is_root() -> bool {
    rank() == 0
}

/// The team, when there is more than one process and the caller is on the thread that may use
/// it.
fn active() -> Option<&'static Registered> {
    TEAM.get()
        .filter(|t| t.team.size() > 1 && t.thread == std::thread::current().id())
}

/// Whether the ranks have agreed ([`agree`]) already.
#[must_use]
pub fn agreed() -> bool {
    TEAM.get().is_none_or(|t| t.agreed.load(Ordering::Relaxed))
}

/// A failure as it travels between ranks: the exit status the CLI gives it (2 for bad input)
/// and its one-line message.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Failure {
    /// 2 for bad input or arguments, 1 otherwise (docs/ARCHITECTURE.md §4.2).
    pub status: u8,
    /// The message, without `error:`.
    pub message: String,
}

impl Failure {
    /// The library error a failure stands for on every rank: an input error for status 2.
    #[must_use]
    pub fn to_error(&self) -> Error {
        if self.status == 2 {
            Error::Invalid(self.message.clone())
        } else {
            Error::Team(self.message.clone())
        }
    }

    fn of(e: &Error) -> Failure {
        Failure {
            status: if e.is_user_error() { 2 } else { 1 },
            message: e.to_string(),
        }
    }
}

/// Encode `Ok(body)` or a failure as one message.
fn encode(result: std::result::Result<Vec<u8>, Failure>) -> Vec<u8> {
    match result {
        Ok(mut body) => {
            body.insert(0, 0);
            body
        }
        Err(f) => {
            let mut out = vec![f.status.max(1)];
            out.extend_from_slice(f.message.as_bytes());
            out
        }
    }
}

fn decode(bytes: &[u8]) -> std::result::Result<&[u8], Failure> {
    match bytes.split_first() {
        Some((0, body)) => Ok(body),
        Some((&status, message)) => Err(Failure {
            status,
            message: String::from_utf8_lossy(message).into_owned(),
        }),
        None => Err(Failure {
            status: 1,
            message: "an empty message between ranks".into(),
        }),
    }
}

/// Rank 0 gathers every rank's message; the first failure by rank (named `rank k:` unless it
/// is rank 0's own) or the concatenation of the bodies in rank order is broadcast to all.
fn gather_verdict(team: &dyn Team, mine: Vec<u8>) -> std::result::Result<Vec<u8>, Failure> {
    let all = team.gather(&mine);
    let mut verdict = Vec::new();
    if team.rank() == 0 {
        let mut body = vec![0u8];
        let mut failure = None;
        for (k, m) in all.iter().enumerate() {
            match decode(m) {
                Ok(b) => body.extend_from_slice(b),
                Err(mut f) => {
                    if k != 0 {
                        f.message = format!("rank {k}: {}", f.message);
                    }
                    failure = Some(f);
                    break;
                }
            }
        }
        verdict = match failure {
            Some(f) => encode(Err(f)),
            None => body,
        };
    }
    team.broadcast(&mut verdict);
    let result = decode(&verdict).map(<[u8]>::to_vec);
    if result.is_err() {
        SHARED_FAILURE.store(true, Ordering::Relaxed);
    }
    result
}

/// The ranks' first collective: each says whether it set its run up (`None`) or how it failed;
/// every rank gets the first failure by rank, or `Ok`. Every rank calls it once, from the
/// first shared batch ([`share_rows`]) or, when its command ends before one, from the end of
/// the command ([`finish`]); so a bad input that stops every rank, or one rank alone, before
/// any collective ends every rank with the same failure, never a hang. No-op without a team or
/// once agreed.
pub fn agree(mine: Option<Failure>) -> std::result::Result<(), Failure> {
    let Some(t) = TEAM.get().filter(|t| t.team.size() > 1) else {
        return mine.map_or(Ok(()), Err);
    };
    if t.agreed.swap(true, Ordering::Relaxed) {
        return mine.map_or(Ok(()), Err);
    }
    gather_verdict(&*t.team, encode(mine.map_or(Ok(Vec::new()), Err))).map(|_| ())
}

/// The end of a command on this rank, `Ok` or its failure: the final outcome every rank
/// reports. Before the ranks have agreed, it is [`agree`] (a rank that fails alone fails them
/// all, with its message). After, a failure can only be this rank's own, outside the shared
/// batches (a file rank 0 writes): rank 0 returns it (the CLI prints it and then calls
/// [`abort`]); the others have nothing to say and end the run at once.
pub fn finish(outcome: std::result::Result<(), Failure>) -> std::result::Result<(), Failure> {
    if !agreed() {
        return agree(outcome.err());
    }
    outcome
}

/// End every process of the run with `status` (without a team: exit this one).
pub fn abort(status: u8) -> ! {
    match TEAM.get() {
        Some(t) if t.team.size() > 1 => t.team.abort(i32::from(status)),
        _ => std::process::exit(i32::from(status)),
    }
}

/// The rows of `0..rows` that `rank` of `size` evaluates: contiguous, in rank order, their
/// lengths differing by at most one.
#[must_use]
pub fn share(rows: usize, rank: usize, size: usize) -> Range<usize> {
    rows * rank / size..rows * (rank + 1) / size
}

/// Evaluate a batch of `rows` rows spread over the ranks: rank 0's `input` (the batch, flat) is
/// broadcast into every rank's, then each rank calls `run(range, input, records)` on its
/// [`share`] with room for `record` bytes a row, and every rank gets every row's record, in
/// order. A rank's failure fails the batch on every rank, with its message. Without a team
/// (or off the team's thread, or with one process) it is `run(0..rows, …)`.
///
/// Every rank must call it in the same order with the same `rows` and `record`; the first call
/// is also the ranks' [`agree`]ment.
pub fn share_rows<T: bytemuck::Pod>(
    rows: usize,
    record: usize,
    input: &mut [T],
    mut run: impl FnMut(Range<usize>, &[T], &mut [u8]) -> Result<()>,
) -> Result<Vec<u8>> {
    let mut run = |range: Range<usize>, input: &[T]| -> Result<Vec<u8>> {
        let mut out = vec![0u8; range.len() * record];
        // A share may be empty (CMA-ES's start: one row).
        if !range.is_empty() {
            run(range, input, &mut out)?;
        }
        Ok(out)
    };
    let Some(t) = active() else {
        return run(0..rows, input);
    };
    let all = share_bytes(t, input, rows, run)?;
    if all.len() != rows * record {
        return Err(Error::Numerical(format!(
            "the ranks returned {} bytes of records for {rows} rows of {record}",
            all.len()
        )));
    }
    Ok(all)
}

/// A row's result as it travels between ranks ([`share_records`]): [`Record::read`] gives back
/// exactly, bit for bit, what [`Record::write`] was given.
pub trait Record: Sized {
    /// Append this record to `out`.
    fn write(&self, out: &mut Writer);
    /// The record `write` wrote, read from `from`.
    fn read(from: &mut Reader<'_>) -> Result<Self>;
}

/// The bytes of [`Record`]s: slices of plain numbers, each after its length.
#[derive(Default)]
pub struct Writer(Vec<u8>);

impl Writer {
    /// Append `items`, after their count.
    pub fn put<T: bytemuck::Pod>(&mut self, items: &[T]) -> &mut Self {
        self.0.extend_from_slice(&(items.len() as u64).to_le_bytes());
        self.0.extend_from_slice(bytemuck::cast_slice(items));
        self
    }

    /// Append one number.
    pub fn one<T: bytemuck::Pod>(&mut self, item: T) -> &mut Self {
        self.put(&[item])
    }
}

/// `r` written and read back whole, as [`share_records`] carries it between ranks: for the
/// tests of a [`Record`], which run without MPI.
#[cfg(test)]
pub(crate) fn round_trip<R: Record>(r: &R) -> Result<R> {
    let mut out = Writer::default();
    r.write(&mut out);
    let mut from = Reader(&out.0);
    let back = R::read(&mut from)?;
    if from.0.is_empty() {
        Ok(back)
    } else {
        Err(Error::Numerical("a record left bytes unread".into()))
    }
}

/// Reads what a [`Writer`] wrote, in the same order.
pub struct Reader<'a>(&'a [u8]);

impl Reader<'_> {
    /// The next slice written with [`Writer::put`].
    pub fn take<T: bytemuck::Pod>(&mut self) -> Result<Vec<T>> {
        let short = || Error::Numerical("a record between ranks ended early".into());
        let (len, rest) = self.0.split_first_chunk::<8>().ok_or_else(short)?;
        let bytes = usize::try_from(u64::from_le_bytes(*len))
            .ok()
            .and_then(|n| n.checked_mul(std::mem::size_of::<T>()))
            .filter(|&b| b <= rest.len())
            .ok_or_else(short)?;
        let (items, rest) = rest.split_at(bytes);
        self.0 = rest;
        Ok(bytemuck::pod_collect_to_vec(items))
    }

    /// The next number written with [`Writer::one`].
    pub fn one<T: bytemuck::Pod>(&mut self) -> Result<T> {
        match self.take::<T>()?[..] {
            [x] => Ok(x),
            _ => Err(Error::Numerical("a record between ranks is malformed".into())),
        }
    }
}

/// [`share_rows`] for results of any size: each rank's `run(range, input)` returns one
/// [`Record`] a row of its share, and every rank gets every row's, in order (the ones run
/// elsewhere written and read back, the same bits). Without a team it is `run(0..rows, input)`.
/// The same rules of calling as [`share_rows`].
pub fn share_records<T: bytemuck::Pod, R: Record>(
    rows: usize,
    input: &mut [T],
    mut run: impl FnMut(Range<usize>, &[T]) -> Result<Vec<R>>,
) -> Result<Vec<R>> {
    let malformed = || Error::Numerical(format!("the ranks did not return {rows} records"));
    let Some(t) = active() else {
        let records = run(0..rows, input)?;
        return if records.len() == rows {
            Ok(records)
        } else {
            Err(malformed())
        };
    };
    let all = share_bytes(t, input, rows, |range, input| {
        let n = range.len();
        let records = if n == 0 { Vec::new() } else { run(range, input)? };
        if records.len() != n {
            return Err(malformed());
        }
        let mut out = Writer::default();
        for r in &records {
            r.write(&mut out);
        }
        Ok(out.0)
    })?;
    let mut from = Reader(&all);
    let records = (0..rows)
        .map(|_| R::read(&mut from))
        .collect::<Result<Vec<R>>>()?;
    if from.0.is_empty() {
        Ok(records)
    } else {
        Err(malformed())
    }
}

/// The collective of [`share_rows`] and [`share_records`] on team `t`: rank 0's `input` is
/// broadcast into every rank's, each rank runs `run` on its [`share`] of `rows`, and every
/// rank gets the ranks' bytes concatenated in rank order (or the first failure).
fn share_bytes<T: bytemuck::Pod>(
    t: &Registered,
    input: &mut [T],
    rows: usize,
    run: impl FnOnce(Range<usize>, &[T]) -> Result<Vec<u8>>,
) -> Result<Vec<u8>> {
    agree(None).map_err(|f| f.to_error())?;
    let team = &*t.team;
    let mut bytes = bytemuck::cast_slice::<T, u8>(input).to_vec();
    team.broadcast(&mut bytes);
    if bytes.len() != std::mem::size_of_val(input) {
        team.abort(1);
    }
    bytemuck::cast_slice_mut::<T, u8>(input).copy_from_slice(&bytes);
    let range = share(rows, team.rank(), team.size());
    let mine = run(range, input)
        .and_then(|out| test_failure(team.rank()).map(|()| out))
        .map_err(|e| Failure::of(&e));
    gather_verdict(team, encode(mine)).map_err(|f| f.to_error())
}

/// The failing rank of `tests/mpi.rs`: with `--features mpi`, the rank that
/// `BEZCHAIN_TEST_FAIL_RANK` names fails every shared batch after evaluating its share.
fn test_failure(rank: usize) -> Result<()> {
    #[cfg(feature = "mpi")]
    if std::env::var("BEZCHAIN_TEST_FAIL_RANK").is_ok_and(|r| r.parse() == Ok(rank)) {
        return Err(Error::Numerical(
            "this rank was told to fail (BEZCHAIN_TEST_FAIL_RANK)".into(),
        ));
    }
    let _ = rank;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shares_cover_the_rows_in_order() {
        for size in 1..5 {
            for rows in 0..12 {
                let mut next = 0;
                for r in 0..size {
                    let s = share(rows, r, size);
                    assert_eq!(s.start, next);
                    assert!(s.len() + 1 >= rows / size && s.len() <= rows / size + 1);
                    next = s.end;
                }
                assert_eq!(next, rows);
            }
        }
    }

    #[test]
    fn messages_round_trip() {
        assert_eq!(decode(&encode(Ok(vec![1, 2]))), Ok(&[1u8, 2][..]));
        let f = Failure {
            status: 2,
            message: "bad".into(),
        };
        assert_eq!(decode(&encode(Err(f.clone()))), Err(f));
    }

    #[test]
    fn one_process_runs_every_row() {
        let mut input = [1.0f32, 2.0, 3.0];
        let out = share_rows(3, 1, &mut input, |r, x, out| {
            for (k, i) in r.enumerate() {
                out[k] = x[i] as u8;
            }
            Ok(())
        })
        .unwrap();
        assert_eq!(out, vec![1, 2, 3]);
    }

    #[derive(Debug, PartialEq)]
    struct Row(Vec<f64>, u32);

    impl Record for Row {
        fn write(&self, out: &mut Writer) {
            out.put(&self.0).one(self.1);
        }
        fn read(from: &mut Reader<'_>) -> Result<Self> {
            Ok(Row(from.take()?, from.one()?))
        }
    }

    #[test]
    fn records_round_trip_bit_for_bit() {
        let rows = [Row(vec![f64::INFINITY, -0.0, 1e-300], 7), Row(Vec::new(), 0)];
        let mut out = Writer::default();
        rows.iter().for_each(|r| r.write(&mut out));
        let mut from = Reader(&out.0[..]);
        for r in &rows {
            let back = Row::read(&mut from).unwrap();
            assert_eq!(back.1, r.1);
            assert!(back.0.iter().zip(&r.0).all(|(a, b)| a.to_bits() == b.to_bits()));
        }
        assert!(from.0.is_empty() && Row::read(&mut from).is_err());
        // A cut record fails, never reads past its end.
        assert!(Row::read(&mut Reader(&out.0[..12])).is_err());
    }

    #[test]
    fn one_process_runs_every_record() {
        let mut input = [3u32, 4];
        let out = share_records(2, &mut input, |r, x| Ok(r.map(|i| Row(vec![], x[i])).collect())).unwrap();
        assert_eq!(out, vec![Row(vec![], 3), Row(vec![], 4)]);
    }
}
