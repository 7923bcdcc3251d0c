//! The order in which directions are baked, and the lifetime of each orientation's grid.
//!
//! Directions sharing a canonical orientation share one oriented copy of the heights (a
//! [`Grid`]). Baking them group by group, each group in parallel, leaves threads idle at the
//! end of every group whose size is not a multiple of the thread count (15 directions fall
//! into groups of 3, 3, 4 and 5). Here every thread takes the next direction in group order as
//! soon as it is free, so a thread that finds its group's directions all taken starts the next
//! group. A group's grid is built by the first direction that needs it and freed when its last
//! direction ends. At most two grids are alive at a time: a direction of group `g` waits until
//! group `g - 2` has ended, so the working memory stays two copies of the heights at most,
//! whatever the thread count.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};

use super::grid::Grid;

/// Runs `bake(group, item, grid)` for every item of every group on one worker per thread of
/// the current rayon pool, taking items in order (group 0's first). `build(group)` makes a group's
/// grid (never called for an empty group). The result does not depend on the schedule: each
/// item sees only its group's grid.
pub(crate) fn run<T: Send>(
    groups: Vec<Vec<T>>,
    build: &(dyn Fn(usize) -> Grid + Sync),
    bake: &(dyn Fn(usize, T, &Grid) + Sync),
) {
    // Empty groups are left out, so "two grids" counts groups that have a grid.
    let groups: Vec<(usize, Vec<T>)> = groups.into_iter().enumerate().filter(|(_, items)| !items.is_empty()).collect();
    let left: Vec<usize> = groups.iter().map(|(_, items)| items.len()).collect();
    let slots = groups.iter().map(|_| Mutex::new(None)).collect();
    // Each item with its group's position among the non-empty groups and the group itself.
    let items: Vec<Mutex<Option<(usize, usize, T)>>> = groups
        .into_iter()
        .enumerate()
        .flat_map(|(n, (g, items))| items.into_iter().map(move |t| Mutex::new(Some((n, g, t)))))
        .collect();
    let grids = Grids { slots, left: Mutex::new(left), ended: Condvar::new() };
    let next = AtomicUsize::new(0);
    let worker = || {
        loop {
            let i = next.fetch_add(1, Ordering::Relaxed);
            let Some(item) = items.get(i) else { break };
            let Some((n, g, t)) = lock(item).take() else { continue };
            // Ends the item even if `build` or `bake` panics, so that no other worker waits
            // for its group forever and the panic reaches the caller. Dropped after `grid`.
            let _ended = Ended { grids: &grids, n };
            let grid = grids.acquire(n, || build(g));
            bake(g, t, &grid);
        }
    };
    rayon::scope(|s| {
        for _ in 1..rayon::current_num_threads() {
            s.spawn(|_| worker());
        }
        worker();
    });
}

/// The grids of the non-empty groups, and how many items of each have not ended.
struct Grids {
    slots: Vec<Mutex<Option<Arc<Grid>>>>,
    left: Mutex<Vec<usize>>,
    /// Signalled when a group ends.
    ended: Condvar,
}

impl Grids {
    /// The grid of group `n`, built by `build` if this is its first item, once group `n - 2`
    /// has ended.
    fn acquire(&self, n: usize, build: impl FnOnce() -> Grid) -> Arc<Grid> {
        if n >= 2 {
            let mut left = lock(&self.left);
            while left[n - 2] > 0 {
                left = self.ended.wait(left).unwrap_or_else(PoisonError::into_inner);
            }
        }
        lock(&self.slots[n]).get_or_insert_with(|| Arc::new(build())).clone()
    }

    /// Marks one item of group `n` ended; the last one frees the group's grid.
    fn release(&self, n: usize) {
        let mut left = lock(&self.left);
        left[n] -= 1;
        if left[n] == 0 {
            lock(&self.slots[n]).take();
            self.ended.notify_all();
        }
    }
}

/// Marks an item of group `n` ended when dropped.
struct Ended<'a> {
    grids: &'a Grids,
    n: usize,
}

impl Drop for Ended<'_> {
    fn drop(&mut self) {
        self.grids.release(self.n);
    }
}

/// Locks `m`; a panic elsewhere has already failed the bake, so a poisoned lock is used as is.
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(tag: usize) -> Grid {
        super::super::grid::Orientation::ALL[0].grid((1, 1), &[tag as f32], 1.0, (1.0, 1.0), 0, false)
    }

    #[test]
    fn every_item_runs_once_with_its_own_groups_grid_and_at_most_two_grids_alive() {
        for threads in [1, 2, 3, 8] {
            let groups: Vec<Vec<usize>> =
                vec![vec![0, 1, 2], vec![3], vec![], vec![4, 5, 6, 7, 8], vec![9, 10], vec![11], vec![]];
            let seen = Mutex::new(vec![0u32; 12]);
            let alive = AtomicUsize::new(0);
            let most = AtomicUsize::new(0);
            let built = Mutex::new(Vec::new());
            let build = |g: usize| {
                built.lock().unwrap().push(g);
                let now = alive.fetch_add(1, Ordering::SeqCst) + 1;
                most.fetch_max(now, Ordering::SeqCst);
                grid(g)
            };
            let group_of = |t: usize| groups.iter().position(|items| items.contains(&t)).unwrap();
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                run(groups.clone(), &build, &|g, t, grid: &Grid| {
                    assert_eq!(g, group_of(t), "item {t} ran with group {g}");
                    assert_eq!(grid.at(0, 0), g as f32, "item {t} got another group's grid");
                    std::thread::sleep(std::time::Duration::from_millis(1 + (t % 3) as u64));
                    // The group's last item frees its grid after this returns; counting the grid
                    // out here keeps `alive` an upper bound.
                    let mut seen = seen.lock().unwrap();
                    seen[t] += 1;
                    if groups[g].iter().all(|&o| seen[o] == 1) {
                        alive.fetch_sub(1, Ordering::SeqCst);
                    }
                });
            });
            assert_eq!(*seen.lock().unwrap(), vec![1; 12], "{threads} threads");
            let mut built = built.into_inner().unwrap();
            built.sort();
            assert_eq!(built, vec![0, 1, 3, 4, 5], "{threads} threads: each grid built once");
            assert!(most.load(Ordering::SeqCst) <= 2, "{threads} threads: {} grids alive", most.load(Ordering::SeqCst));
        }
    }

    #[test]
    fn a_panicking_item_reaches_the_caller_instead_of_stalling_the_others() {
        // Item 0 panics; the other worker soon needs group 2, which waits for group 0 to end.
        let (done, finished) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
            let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                pool.install(|| {
                    let groups = vec![vec![0usize, 1], vec![2], vec![3, 4]];
                    run(groups, &grid, &|_, t, _: &Grid| {
                        if t == 0 {
                            std::thread::sleep(std::time::Duration::from_millis(20));
                            panic!("item 0 fails");
                        }
                    });
                })
            }));
            done.send(outcome.is_err()).unwrap();
        });
        // A generous bound on a run of five empty items: reaching it means the workers hung.
        let panicked = finished.recv_timeout(std::time::Duration::from_secs(60)).expect("the run hung");
        assert!(panicked, "the panic of item 0 was lost");
    }
}
