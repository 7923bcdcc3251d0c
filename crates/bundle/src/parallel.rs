//! The one parallel loop this crate needs, without a thread-pool dependency: checking tens of
//! thousands of tile entries when a manifest opens, and comparing two bundles asset by asset.

use std::sync::atomic::{AtomicUsize, Ordering};

/// `f(index, item)` for every item, on up to every core, results in item order. Each thread
/// takes the next item not yet taken, so items of very different cost (a large horizon map
/// beside a small mesh) keep every core busy. Fewer than `serial_below` items run on the
/// calling thread, where starting threads would cost more than the work.
pub(crate) fn map<T: Sync, R: Send>(items: &[T], serial_below: usize, f: impl Fn(usize, &T) -> R + Sync) -> Vec<R> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(items.len());
    if items.len() < serial_below.max(2) || threads <= 1 {
        return items.iter().enumerate().map(|(i, t)| f(i, t)).collect();
    }
    let next = AtomicUsize::new(0);
    let (f, next) = (&f, &next);
    let mut done: Vec<(usize, R)> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|_| {
                scope.spawn(move || {
                    let mut mine = Vec::new();
                    loop {
                        let i = next.fetch_add(1, Ordering::Relaxed);
                        let Some(item) = items.get(i) else { break };
                        mine.push((i, f(i, item)));
                    }
                    mine
                })
            })
            .collect();
        handles.into_iter().flat_map(|h| h.join().expect("the work never panics")).collect()
    });
    done.sort_unstable_by_key(|(i, _)| *i);
    done.into_iter().map(|(_, r)| r).collect()
}

#[cfg(test)]
mod tests {
    /// Results come back in item order, whatever thread made each and however long it took.
    #[test]
    fn results_keep_the_items_order() {
        let items: Vec<u64> = (0..5000).collect();
        let out = super::map(&items, 0, |i, &v| {
            if v % 97 == 0 {
                std::thread::sleep(std::time::Duration::from_micros(200));
            }
            (i as u64, v * 3)
        });
        assert!(out.iter().enumerate().all(|(i, &(j, v))| i as u64 == j && v == 3 * i as u64));
        assert_eq!(super::map(&items[..3], 4096, |_, &v| v), vec![0, 1, 2]);
    }
}
