//! Work that takes longer than a frame (cumulus shapes, optics tables,
//! terrain), run on a worker thread so that `prepare` never stalls the
//! caller's render thread: each frame asks for the value of its current
//! inputs and gets the newest one ready, possibly of older inputs, or none
//! yet.

use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

/// Where precomputation runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Precompute {
    /// On worker threads: `prepare` returns at once and frames draw what is
    /// ready (the sky first, the clouds once their shapes exist). For an
    /// application's render loop.
    #[default]
    Background,
    /// On the calling thread, inside `prepare`: every frame is complete.
    /// For offline rendering (the command-line tool, tests).
    Blocking,
}

/// A value computed from a key, on a worker thread
/// ([`Precompute::Background`]) or inline ([`Precompute::Blocking`]).
#[derive(Debug)]
pub struct Deferred<K, V> {
    /// Names the work for [`Self::pending`] (e.g. "cumulus shapes").
    what: &'static str,
    /// The newest value computed, and its key.
    ready: Option<(K, V)>,
    /// The computation under way, and its key (`None` from the thread only
    /// if it found its work taken, which cannot happen once spawned).
    running: Option<(K, JoinHandle<Option<V>>)>,
}

impl<K: PartialEq, V: Send + 'static> Deferred<K, V> {
    /// Nothing computed yet.
    pub fn new(what: &'static str) -> Self {
        Self {
            what,
            ready: None,
            running: None,
        }
    }

    /// Makes sure the value of `key` is ready or under way, and returns the
    /// newest ready value with its key: `key`'s once computed, until then
    /// the previous key's, or `None` before the first is done. `job` is
    /// called only when `key` is neither ready nor under way, and gives the
    /// computation (so that what it copies for the worker is copied only
    /// then, not every frame). One computation
    /// at a time: while another key's is under way (threads cannot be
    /// cancelled), `key`'s waits for a request after it has finished, so a
    /// key that changes every frame (a moving sun) is followed with a lag
    /// of one computation instead of piling up threads.
    pub fn request<F: FnOnce() -> V + Send + 'static>(
        &mut self,
        key: K,
        mode: Precompute,
        job: impl FnOnce() -> F,
    ) -> Option<(&K, &V)> {
        self.collect(mode == Precompute::Blocking);
        let ready = self.ready.as_ref().is_some_and(|(k, _)| *k == key);
        if !ready && self.running.is_none() {
            let compute = job();
            match mode {
                Precompute::Blocking => self.ready = Some((key, compute())),
                Precompute::Background => {
                    // Kept here too, so that it can still run if no thread can be had.
                    let slot = Arc::new(Mutex::new(Some(compute)));
                    let worker = slot.clone();
                    let thread = std::thread::Builder::new()
                        .name(format!("nimbus {}", self.what))
                        .spawn(move || {
                            let compute = worker.lock().unwrap_or_else(|e| e.into_inner()).take();
                            compute.map(|compute| compute())
                        });
                    match thread {
                        Ok(handle) => self.running = Some((key, handle)),
                        // No thread to be had (a limit on threads): compute
                        // here rather than never.
                        Err(_) => {
                            let compute = slot.lock().unwrap_or_else(|e| e.into_inner()).take();
                            if let Some(compute) = compute {
                                self.ready = Some((key, compute()));
                            }
                        }
                    }
                }
            }
        }
        self.ready()
    }

    /// [`Self::request`], giving the value only once it is `key`'s (not an
    /// older key's).
    pub fn request_current<F: FnOnce() -> V + Send + 'static>(
        &mut self,
        key: &K,
        mode: Precompute,
        job: impl FnOnce() -> F,
    ) -> Option<&V>
    where
        K: Clone,
    {
        self.request(key.clone(), mode, job)
            .filter(|(ready, _)| *ready == key)
            .map(|(_, value)| value)
    }

    /// Takes the running computation's result if it has finished (or waits
    /// for it when `wait`). A panic of the computation is resumed here, on
    /// the caller's thread, as if it had run inline.
    fn collect(&mut self, wait: bool) {
        let finished = self
            .running
            .as_ref()
            .is_some_and(|(_, handle)| wait || handle.is_finished());
        if !finished {
            return;
        }
        if let Some((key, handle)) = self.running.take() {
            match handle.join() {
                Ok(Some(value)) => self.ready = Some((key, value)),
                Ok(None) => {}
                Err(panic) => std::panic::resume_unwind(panic),
            }
        }
    }

    /// Blocks until the computation under way, if any, has finished.
    pub fn wait(&mut self) {
        self.collect(true);
    }

    /// The work's name while a computation is under way.
    pub fn pending(&self) -> Option<&'static str> {
        self.running.as_ref().map(|_| self.what)
    }

    /// The newest ready value and its key, without asking for anything.
    pub fn ready(&self) -> Option<(&K, &V)> {
        self.ready.as_ref().map(|(k, v)| (k, v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc;

    #[test]
    fn background_returns_the_previous_value_until_the_new_one_is_done() {
        let mut d: Deferred<u32, u32> = Deferred::new("test");
        let (release, gate) = mpsc::channel::<()>();
        assert!(
            d.request(1, Precompute::Background, || move || {
                gate.recv().expect("released");
                10
            })
            .is_none()
        );
        assert_eq!(d.pending(), Some("test"));
        // Asking again for the same key starts nothing new.
        assert!(
            d.request(1, Precompute::Background, || -> fn() -> u32 {
                unreachable!()
            })
            .is_none()
        );
        release.send(()).expect("worker waiting");
        d.wait();
        assert_eq!(d.pending(), None);
        assert_eq!(d.ready(), Some((&1, &10)));
        // A new key: the old value stays until the new one is computed.
        let (release, gate) = mpsc::channel::<()>();
        let got = d.request(2, Precompute::Background, || {
            move || {
                gate.recv().expect("released");
                20
            }
        });
        assert_eq!(got, Some((&1, &10)));
        // A third key while the second is under way waits for it.
        assert_eq!(
            d.request(3, Precompute::Background, || -> fn() -> u32 {
                unreachable!()
            }),
            Some((&1, &10))
        );
        release.send(()).expect("worker waiting");
        d.wait();
        assert_eq!(d.ready(), Some((&2, &20)));
        d.request(3, Precompute::Background, || || 30);
        d.wait();
        assert_eq!(
            d.request_current(&3, Precompute::Background, || -> fn() -> u32 {
                unreachable!()
            }),
            Some(&30)
        );
    }

    #[test]
    fn blocking_computes_inline() {
        let mut d: Deferred<u32, u32> = Deferred::new("test");
        assert_eq!(
            d.request(3, Precompute::Blocking, || || 30),
            Some((&3, &30))
        );
        assert_eq!(d.pending(), None);
    }

    #[test]
    fn a_panic_in_the_worker_reaches_the_caller() {
        let mut d: Deferred<u32, u32> = Deferred::new("test");
        d.request(1, Precompute::Background, || {
            || -> u32 { panic!("worker failed") }
        });
        let caught = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| d.wait()));
        assert!(caught.is_err());
    }
}
