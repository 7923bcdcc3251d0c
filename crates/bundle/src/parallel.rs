//! The one parallel loop this crate needs: checking tens of thousands of tile entries on every
//! core when a manifest opens, without a thread-pool dependency.

/// `f(index, item)` for every item, on up to every core, in item order. Small inputs run on
/// the calling thread.
pub(crate) fn map<T: Sync, R: Send>(items: &[T], f: impl Fn(usize, &T) -> R + Sync) -> Vec<R> {
    const SERIAL_BELOW: usize = 4096;
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    if items.len() < SERIAL_BELOW || threads == 1 {
        return items.iter().enumerate().map(|(i, t)| f(i, t)).collect();
    }
    let chunk = items.len().div_ceil(threads);
    let f = &f;
    std::thread::scope(|scope| {
        let handles: Vec<_> = items
            .chunks(chunk)
            .enumerate()
            .map(|(c, part)| {
                scope.spawn(move || part.iter().enumerate().map(|(i, t)| f(c * chunk + i, t)).collect::<Vec<R>>())
            })
            .collect();
        handles.into_iter().flat_map(|h| h.join().expect("a check never panics")).collect()
    })
}
