//! The machine's FP32 multiply-add peak, for judging the evaluator's throughput: what the
//! cores, FMA datapath and clock allow on paper ([`CpuPeak::detect`]), and what a loop of
//! independent FMAs reaches on them ([`measure_fma`]).
//!
//! **On paper.** `peak = cores × FMA units × datapath lanes × 2 FLOP × clock`. The datapath is
//! the width the FMA units execute, which is not always the widest instruction set: AMD Zen 4
//! (family 25, models 0x10-0x1f, 0x60-0x7f, 0xa0-0xaf) runs AVX-512 instructions on two
//! 256-bit FMA pipes, one 512-bit FMA taking both halves, so its FP32 peak is 2 × 8 × 2 = 32
//! FLOP a cycle and core with AVX-512 or AVX2 alike, not the 64 of a 512-bit datapath with two
//! units (Intel's server cores, AMD Zen 5). The table: AMD families 23 (Zen 1: 128-bit; Zen 2:
//! 256-bit) and 25 (Zen 3, Zen 4: 256-bit); other CPUs with AVX-512F: 512-bit; with AVX2 and
//! FMA: 256-bit; else 128-bit; two FMA units throughout (some Intel Xeon Bronze/Silver parts
//! have one 512-bit unit: pass the figure explicitly there). The clock is measured: a chain of
//! dependent integer additions (one cycle each on every x86 core) timed on the thread's CPU
//! clock, so turbo clocks count and other jobs on the machine do not; where that is not
//! available, the clock the OS reports (`cpu MHz` in `/proc/cpuinfo`; under a hypervisor, the
//! nominal TSC clock, which can be far below the clock the cores run at).
//!
//! **Measured.** [`measure_fma`] runs, on every rayon thread at once, independent chains of
//! `a = a · m + c` in registers (AVX-512: 16 zmm; AVX2: 12 ymm, enough to cover FMA latency on
//! every core since Haswell) and divides each thread's FLOPs by the CPU time it got (on Unix;
//! elsewhere by the wall time): the rate of a busy core, which other jobs sharing the machine
//! do not lower, times the cores, and the FLOPs a cycle at the reported clock.

use serde::Serialize;
use std::time::Instant;

/// The processor as detected, and its FP32 FMA peak on paper.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CpuPeak {
    /// The model name the OS reports.
    pub model: String,
    /// Vendor string (`AuthenticAMD`, `GenuineIntel`, …; empty off x86).
    pub vendor: String,
    /// CPUID family (base plus extended).
    pub family: u32,
    /// CPUID model (with the extended bits).
    pub model_id: u32,
    /// Cores used: the rayon threads.
    pub cores: usize,
    /// The widest FMA instruction set: 512 (AVX-512F), 256 (AVX2 + FMA) or 128.
    pub vector_bits: u32,
    /// The width the FMA units execute (see the module notes).
    pub datapath_bits: u32,
    /// FMA units a core.
    pub fma_units: u32,
    /// Clock, GHz: measured (see the module notes), else as reported.
    pub ghz: f64,
    /// The clock the OS reports, GHz (0 where it reports none).
    pub ghz_reported: f64,
    /// FP32 FLOP a cycle and core: `fma_units × datapath_bits / 32 × 2`.
    pub flop_per_cycle: f64,
    /// `cores × flop_per_cycle × ghz`.
    pub gflops: f64,
}

impl CpuPeak {
    /// Detect this machine's peak (see the module notes for the table).
    #[must_use]
    pub fn detect() -> Self {
        let (vendor, family, model_id) = cpuid();
        let vector_bits = vector_bits();
        let amd = vendor == "AuthenticAMD";
        let datapath_bits = match (amd, family) {
            (true, 23) if model_id < 0x30 => 128,
            (true, 23 | 25) => vector_bits.min(256),
            _ => vector_bits,
        };
        let fma_units = 2;
        let cores = rayon::current_num_threads();
        let ghz_reported = cpu_mhz().unwrap_or(0.0) / 1000.0;
        let ghz = measure_ghz().unwrap_or(ghz_reported);
        let flop_per_cycle = f64::from(fma_units * datapath_bits / 32 * 2);
        CpuPeak {
            model: model_name().unwrap_or_default(),
            vendor,
            family,
            model_id,
            cores,
            vector_bits,
            datapath_bits,
            fma_units,
            ghz,
            ghz_reported,
            flop_per_cycle,
            gflops: cores as f64 * flop_per_cycle * ghz,
        }
    }
}

/// `(vendor, family, model)` from CPUID leaf 0 and 1 (empty and zeros off x86_64).
fn cpuid() -> (String, u32, u32) {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: CPUID leaves 0 and 1 exist on every x86_64 processor (the call is safe from
        // Rust 1.94 on; unsafe before).
        #[allow(unused_unsafe)]
        let (l0, l1) = unsafe { (std::arch::x86_64::__cpuid(0), std::arch::x86_64::__cpuid(1)) };
        let bytes: Vec<u8> = [l0.ebx, l0.edx, l0.ecx]
            .iter()
            .flat_map(|r| r.to_le_bytes())
            .collect();
        let vendor = String::from_utf8_lossy(&bytes).into_owned();
        let base_family = (l1.eax >> 8) & 0xf;
        let base_model = (l1.eax >> 4) & 0xf;
        let family = if base_family == 0xf {
            base_family + ((l1.eax >> 20) & 0xff)
        } else {
            base_family
        };
        let model = if base_family == 0x6 || base_family == 0xf {
            (((l1.eax >> 16) & 0xf) << 4) | base_model
        } else {
            base_model
        };
        (vendor, family, model)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        (String::new(), 0, 0)
    }
}

/// The widest FMA instruction set this CPU runs.
fn vector_bits() -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            return 512;
        }
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            return 256;
        }
    }
    128
}

/// The core clock in GHz: dependent register additions counted against the thread's CPU
/// time (the median of five timings of about 20 ms). The addend is a register, not an
/// immediate: Golden Cove cores (Sapphire Rapids Xeons) fold chains of `add reg, imm` at
/// rename, several a cycle, and such a chain timed 18-21 "GHz" on a 3.45 GHz core (register
/// additions and 3-cycle `imul` chains both give 3.45 there).
fn measure_ghz() -> Option<f64> {
    #[cfg(target_arch = "x86_64")]
    {
        /// Dependent additions a round.
        const CHAIN: u64 = 32;
        let time = |rounds: u64| -> Option<f64> {
            let start = thread_cpu_seconds()?;
            let mut x = 0u64;
            let one = std::hint::black_box(1u64);
            for _ in 0..rounds {
                // SAFETY: register arithmetic only.
                unsafe {
                    std::arch::asm!(
                        "add {x}, {one}", "add {x}, {one}", "add {x}, {one}", "add {x}, {one}",
                        "add {x}, {one}", "add {x}, {one}", "add {x}, {one}", "add {x}, {one}",
                        "add {x}, {one}", "add {x}, {one}", "add {x}, {one}", "add {x}, {one}",
                        "add {x}, {one}", "add {x}, {one}", "add {x}, {one}", "add {x}, {one}",
                        "add {x}, {one}", "add {x}, {one}", "add {x}, {one}", "add {x}, {one}",
                        "add {x}, {one}", "add {x}, {one}", "add {x}, {one}", "add {x}, {one}",
                        "add {x}, {one}", "add {x}, {one}", "add {x}, {one}", "add {x}, {one}",
                        "add {x}, {one}", "add {x}, {one}", "add {x}, {one}", "add {x}, {one}",
                        x = inout(reg) x,
                        one = in(reg) one,
                        options(nomem, nostack),
                    );
                }
            }
            std::hint::black_box(x);
            Some(thread_cpu_seconds()? - start)
        };
        let rounds = 1 << 21;
        let mut t: Vec<f64> = (0..5).map(|_| time(rounds)).collect::<Option<_>>()?;
        t.sort_by(f64::total_cmp);
        (t[2] > 0.0).then(|| (rounds * CHAIN) as f64 / t[2] / 1e9)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        None
    }
}

/// A field of the first processor in `/proc/cpuinfo`.
fn cpuinfo(field: &str) -> Option<String> {
    let text = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    text.lines().find_map(|line| {
        let (k, v) = line.split_once(':')?;
        (k.trim() == field).then(|| v.trim().to_owned())
    })
}

fn cpu_mhz() -> Option<f64> {
    cpuinfo("cpu MHz")?.parse().ok()
}

fn model_name() -> Option<String> {
    cpuinfo("model name")
}

/// An instruction set for [`measure_fma`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FmaSet {
    /// 512-bit `vfmadd` on zmm registers.
    Avx512,
    /// 256-bit `vfmadd` on ymm registers.
    Avx2,
}

/// What [`measure_fma`] found.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FmaRate {
    /// FP32 GFLOP/s of all cores: a busy core's rate (FLOPs over its CPU time) times the cores.
    pub gflops: f64,
    /// FLOPs a cycle and core at the measured clock (see [`CpuPeak::ghz`]).
    pub flop_per_cycle: f64,
    /// FP32 GFLOP/s over the wall time (lower when other jobs share the cores).
    pub wall_gflops: f64,
}

/// Independent FMAs in `set` on every rayon thread at once, over about `seconds` (the median
/// of five timings); `None` when this CPU lacks the set.
#[must_use]
pub fn measure_fma(set: FmaSet, seconds: f64) -> Option<FmaRate> {
    #[cfg(target_arch = "x86_64")]
    {
        let kernel: unsafe fn(u64) -> f32 = match set {
            FmaSet::Avx512 if std::arch::is_x86_feature_detected!("avx512f") => x86::fma_avx512,
            FmaSet::Avx2
                if std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma") =>
            {
                x86::fma_avx2
            }
            _ => return None,
        };
        let flop_per_round = match set {
            FmaSet::Avx512 => x86::CHAINS_512 * 16 * 2,
            FmaSet::Avx2 => x86::CHAINS_256 * 8 * 2,
        } as f64;
        let threads = rayon::current_num_threads();
        // (wall seconds, the threads' mean CPU seconds) of `rounds` rounds on every thread.
        let run = |rounds: u64| -> (f64, f64) {
            let start = Instant::now();
            let per_thread: Vec<(f32, f64)> = rayon::broadcast(|_| {
                let cpu = thread_cpu_seconds();
                // SAFETY: the feature was detected above.
                let sink = unsafe { kernel(rounds) };
                (
                    sink,
                    thread_cpu_seconds().zip(cpu).map_or(f64::NAN, |(b, a)| b - a),
                )
            });
            let wall = start.elapsed().as_secs_f64();
            std::hint::black_box(per_thread.iter().map(|p| p.0).sum::<f32>());
            let cpu = per_thread.iter().map(|p| p.1).sum::<f64>() / threads as f64;
            (wall, if cpu.is_finite() && cpu > 0.0 { cpu } else { wall })
        };
        // Size the rounds to a fifth of `seconds` a timing.
        let mut rounds = 1u64 << 16;
        while run(rounds).0 < seconds / 20.0 && rounds < 1 << 40 {
            rounds *= 2;
        }
        let mut timings: Vec<(f64, f64)> = (0..5).map(|_| run(rounds * 4)).collect();
        let flops = threads as f64 * (rounds * 4) as f64 * flop_per_round;
        let median = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let wall = median(&mut timings.iter().map(|t| t.0).collect());
        let cpu = median(&mut timings.iter_mut().map(|t| t.1).collect());
        let gflops = flops / cpu / 1e9;
        let ghz = measure_ghz()
            .or_else(|| cpu_mhz().map(|m| m / 1000.0))
            .unwrap_or(f64::NAN);
        Some(FmaRate {
            gflops,
            flop_per_cycle: gflops / threads as f64 / ghz,
            wall_gflops: flops / wall / 1e9,
        })
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (set, seconds);
        None
    }
}

/// The calling thread's CPU time, seconds (`None` where not available).
fn thread_cpu_seconds() -> Option<f64> {
    #[cfg(unix)]
    {
        cpu_clock(libc::CLOCK_THREAD_CPUTIME_ID)
    }
    #[cfg(not(unix))]
    {
        None
    }
}

/// The process's CPU time (all its threads), seconds (`None` where not available).
#[must_use]
pub fn process_cpu_seconds() -> Option<f64> {
    #[cfg(unix)]
    {
        cpu_clock(libc::CLOCK_PROCESS_CPUTIME_ID)
    }
    #[cfg(not(unix))]
    {
        None
    }
}

#[cfg(unix)]
fn cpu_clock(clock: libc::clockid_t) -> Option<f64> {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid timespec for the call to fill.
    let ok = unsafe { libc::clock_gettime(clock, &mut t) } == 0;
    ok.then_some(t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9)
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::*;

    /// Independent chains: more than FMA latency × issue width on any core.
    pub const CHAINS_512: usize = 16;
    /// Twelve of the sixteen ymm registers.
    pub const CHAINS_256: usize = 12;

    /// `rounds` rounds of one FMA on each of the zmm chains; returns a sum that depends on all.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn fma_avx512(rounds: u64) -> f32 {
        let m = _mm512_set1_ps(0.999_999);
        let c = _mm512_set1_ps(1e-7);
        let mut acc = [_mm512_set1_ps(1.0); CHAINS_512];
        for _ in 0..rounds {
            for a in &mut acc {
                *a = _mm512_fmadd_ps(*a, m, c);
            }
        }
        let mut s = _mm512_setzero_ps();
        for a in acc {
            s = _mm512_add_ps(s, a);
        }
        _mm512_reduce_add_ps(s)
    }

    /// The same on the ymm chains.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn fma_avx2(rounds: u64) -> f32 {
        let m = _mm256_set1_ps(0.999_999);
        let c = _mm256_set1_ps(1e-7);
        let mut acc = [_mm256_set1_ps(1.0); CHAINS_256];
        for _ in 0..rounds {
            for a in &mut acc {
                *a = _mm256_fmadd_ps(*a, m, c);
            }
        }
        let mut s = _mm256_setzero_ps();
        for a in acc {
            s = _mm256_add_ps(s, a);
        }
        let mut out = [0.0f32; 8];
        _mm256_storeu_ps(out.as_mut_ptr(), s);
        out.iter().sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thread_has_a_cpu_clock() {
        if cfg!(unix) {
            let a = thread_cpu_seconds().unwrap();
            let mut x = 0u64;
            for i in 0..1_000_000u64 {
                x = x.wrapping_mul(31).wrapping_add(i);
            }
            std::hint::black_box(x);
            assert!(thread_cpu_seconds().unwrap() >= a);
        }
    }

    #[test]
    fn the_paper_peak_is_its_product() {
        let p = CpuPeak::detect();
        assert!(p.cores >= 1 && p.fma_units == 2);
        assert!([128, 256, 512].contains(&p.datapath_bits) && p.datapath_bits <= p.vector_bits);
        assert_eq!(p.flop_per_cycle, f64::from(p.datapath_bits / 32 * 2 * 2));
        assert!((p.gflops - p.cores as f64 * p.flop_per_cycle * p.ghz).abs() < 1e-9);
        if p.vendor == "AuthenticAMD" && p.family == 25 {
            assert_eq!(p.datapath_bits, 256, "Zen 3 and Zen 4 execute 256 bits a pipe");
        }
    }

    /// The clock is measured over the thread's CPU time, so load does not lower it; a chain the
    /// core shortcuts raises it far beyond any clock (an immediate-add chain timed 18-21 GHz on
    /// a Sapphire Rapids core). No x86 core runs above 7 GHz or below 0.5.
    #[test]
    fn the_measured_clock_is_a_clock() {
        if let Some(ghz) = measure_ghz() {
            assert!((0.5..7.0).contains(&ghz), "measured {ghz} GHz");
        }
    }
}
