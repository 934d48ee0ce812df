//! Threads: candle's CPU backend's thread count, the allocator's tuning,
//! and a thread's scheduling priority.
//!
//! candle 0.11 reads `RAYON_NUM_THREADS` on every matrix multiplication
//! ([`candle_core::utils::get_num_threads`]; more than one thread means gemm
//! runs on rayon's global pool) and sizes its element-wise worker pool once,
//! from `CANDLE_NUM_THREADS` (falling back to `RAYON_NUM_THREADS`, then the
//! physical cores), at the first large element-wise op. Both must therefore
//! be set before the first tensor operation of the process.
//!
//! Measured on the 2-core dev machine (see `policy/benches/inference.rs`):
//! for the actors' batches of 64 rows one thread is fastest — the matrices
//! are far too small to amortise waking a second thread.

/// Threads candle's CPU matmul currently uses.
pub fn candle_threads() -> usize {
    candle_core::utils::get_num_threads()
}

/// Pins candle (matmul and element-wise pools) and rayon's global pool to
/// `n` threads, unless the user already set `RAYON_NUM_THREADS` /
/// `CANDLE_NUM_THREADS`. Call it at the start of `main`, before any other
/// thread exists and before any tensor operation. Returns the thread count
/// candle will use.
///
/// ```
/// let n = buridan_policy::threads::pin_threads(1);
/// assert!(n >= 1);
/// ```
pub fn pin_threads(n: usize) -> usize {
    let n = n.max(1).to_string();
    for var in ["RAYON_NUM_THREADS", "CANDLE_NUM_THREADS"] {
        if std::env::var_os(var).is_none() {
            // Setting the environment is only sound while no other thread
            // reads it: the documented contract of this function.
            std::env::set_var(var, &n);
        }
    }
    tune_allocator();
    candle_threads()
}

/// Keeps freed tensor buffers in the process instead of returning them to
/// the OS after every operation (glibc: `M_MMAP_THRESHOLD` 32 MiB,
/// `M_TRIM_THRESHOLD` 256 MiB). Training allocates and frees buffers of
/// hundreds of KiB per op; with glibc's defaults a quarter of a PPO update
/// went to page faults. Safe to call at any time; a no-op elsewhere.
pub fn tune_allocator() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only adjusts allocator parameters; it takes the
    // allocator's own lock and is safe to call from any thread.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 256 << 20);
    }
}

/// Lowers the calling thread's scheduling priority to niceness `nice`
/// (0–19; threads it starts afterwards inherit it), so that on a machine
/// it shares with the learner an actor process yields the cores to the
/// learner's update thread, the run's bottleneck
/// (`docs/results/transport/RESULTS.md`). Call it at the start of `main`,
/// before any other thread exists. Lowering needs no privileges; nothing
/// here raises a priority. Linux only: elsewhere an `Unsupported` error.
///
/// ```
/// # #[cfg(target_os = "linux")]
/// std::thread::spawn(|| buridan_policy::threads::lower_priority(1).unwrap()).join().unwrap();
/// assert!(buridan_policy::threads::lower_priority(20).is_err());
/// ```
pub fn lower_priority(nice: u8) -> std::io::Result<()> {
    if nice > 19 {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("niceness {nice} is outside 0..=19"),
        ));
    }
    #[cfg(target_os = "linux")]
    {
        // SAFETY: setpriority only changes the scheduling attributes of the
        // calling thread (Linux applies PRIO_PROCESS with who = 0 to the
        // calling thread); it touches no memory of ours.
        let rc = unsafe { libc::setpriority(libc::PRIO_PROCESS, 0, libc::c_int::from(nice)) };
        if rc == 0 {
            Ok(())
        } else {
            Err(std::io::Error::last_os_error())
        }
    }
    #[cfg(not(target_os = "linux"))]
    {
        Err(std::io::Error::new(
            std::io::ErrorKind::Unsupported,
            "lowering a thread's priority is implemented for Linux only",
        ))
    }
}
