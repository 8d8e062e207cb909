//! Real-time scheduling for the arm threads.
//!
//! A control computer runs the streaming threads under `SCHED_FIFO`, so that neither the
//! planner nor anything else on the machine delays a cycle or a quick stop. Asking for it needs
//! `CAP_SYS_NICE` (or an `rtprio` limit); without it the threads run at normal priority and the
//! report says why.

use crate::run::RealtimeRefused;

/// Puts the calling thread under `SCHED_FIFO` at `priority` (1 to 99). The error carries the
/// reason the system gave.
#[cfg(target_os = "linux")]
pub fn make_realtime(priority: u8) -> Result<(), RealtimeRefused> {
    let param = libc::sched_param {
        sched_priority: i32::from(priority),
    };
    // SAFETY: pthread_self() is the calling thread and `param` outlives the call.
    let rc = unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
    if rc == 0 {
        Ok(())
    } else {
        Err(RealtimeRefused::Refused {
            priority,
            errno: rc,
        })
    }
}

#[cfg(not(target_os = "linux"))]
pub fn make_realtime(priority: u8) -> Result<(), RealtimeRefused> {
    Err(RealtimeRefused::Unsupported(priority))
}
