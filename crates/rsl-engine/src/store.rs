//! Prepared data in memory, by content key, under a byte budget with least-recently-used
//! eviction.
//!
//! Everything here can be rebuilt (or read back from the disk cache), so evicting is always
//! safe. What the current scene uses is *pinned* ([`Store::pin`]) and never evicted: the
//! resident total can exceed the budget only when the pinned data alone does.

use std::any::Any;
use std::collections::{HashMap, HashSet};
use std::sync::Arc;

/// Memory budget of an engine that is given none: 2 GiB.
pub const DEFAULT_BUDGET: usize = 2 << 30;

struct Entry {
    item: Arc<dyn Any + Send + Sync>,
    bytes: usize,
    last_used: u64,
}

/// Prepared items by content key.
pub struct Store {
    entries: HashMap<u64, Entry>,
    pinned: HashSet<u64>,
    clock: u64,
    budget: usize,
    resident: usize,
    evictions: u64,
}

impl Store {
    /// An empty store holding at most `budget` bytes of unpinned data.
    pub fn new(budget: usize) -> Self {
        Self { entries: HashMap::new(), pinned: HashSet::new(), clock: 0, budget, resident: 0, evictions: 0 }
    }

    /// The item under `key` (marking it used), if it is held and of type `T`.
    pub fn get<T: Any + Send + Sync>(&mut self, key: u64) -> Option<Arc<T>> {
        self.clock += 1;
        let e = self.entries.get_mut(&key)?;
        e.last_used = self.clock;
        e.item.clone().downcast::<T>().ok()
    }

    /// Holds `item` (of `bytes` bytes) under `key`, then evicts what the budget requires.
    pub fn insert<T: Any + Send + Sync>(&mut self, key: u64, item: Arc<T>, bytes: usize) {
        self.clock += 1;
        if let Some(old) = self.entries.insert(key, Entry { item, bytes, last_used: self.clock }) {
            self.resident -= old.bytes;
        }
        self.resident += bytes;
        self.evict();
    }

    /// Marks exactly `keys` as in use (never evicted); everything else becomes evictable.
    pub fn pin(&mut self, keys: impl IntoIterator<Item = u64>) {
        self.pinned = keys.into_iter().collect();
        self.evict();
    }

    /// Adds `keys` to the pinned set (for data about to be built for the scene in use).
    pub fn pin_more(&mut self, keys: impl IntoIterator<Item = u64>) {
        self.pinned.extend(keys);
    }

    /// Evicts least-recently-used unpinned items until the budget holds (or only pinned
    /// items are left).
    fn evict(&mut self) {
        while self.resident > self.budget {
            let victim = self
                .entries
                .iter()
                .filter(|(k, _)| !self.pinned.contains(k))
                .min_by_key(|(_, e)| e.last_used)
                .map(|(k, _)| *k);
            let Some(k) = victim else { break };
            let e = self.entries.remove(&k).expect("the victim is held");
            self.resident -= e.bytes;
            self.evictions += 1;
        }
    }

    /// Whether `key` is held.
    pub fn contains(&self, key: u64) -> bool {
        self.entries.contains_key(&key)
    }

    /// Bytes held.
    pub fn resident_bytes(&self) -> usize {
        self.resident
    }

    /// The budget, bytes.
    pub fn budget(&self) -> usize {
        self.budget
    }

    /// Items evicted so far.
    pub fn evictions(&self) -> u64 {
        self.evictions
    }

    /// Items held.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether nothing is held.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn least_recently_used_unpinned_items_go_first() {
        let mut s = Store::new(30);
        s.insert(1, Arc::new(1u8), 10);
        s.insert(2, Arc::new(2u8), 10);
        s.insert(3, Arc::new(3u8), 10);
        assert_eq!(s.resident_bytes(), 30);
        assert!(s.get::<u8>(1).is_some(), "touch 1: 2 is now the oldest");
        s.insert(4, Arc::new(4u8), 10);
        assert!(!s.contains(2) && s.contains(1) && s.contains(3) && s.contains(4));
        assert_eq!((s.resident_bytes(), s.evictions()), (30, 1));
        // With everything else pinned, an unpinned newcomer is the one to go.
        s.pin([1, 3, 4]);
        s.insert(5, Arc::new(5u8), 25);
        assert!(s.contains(1) && s.contains(3) && s.contains(4) && !s.contains(5));
        // Pinned items stay even over budget; unpinning lets them go.
        s.pin_more([5]);
        s.insert(5, Arc::new(5u8), 25);
        assert_eq!(s.resident_bytes(), 55);
        s.pin([5]);
        assert_eq!(s.resident_bytes(), 25, "only the new pin is left");
        assert!(s.contains(5) && s.len() == 1);
    }

    #[test]
    fn a_key_of_another_type_is_not_served() {
        let mut s = Store::new(100);
        s.insert(7, Arc::new(1.5f32), 4);
        assert!(s.get::<u32>(7).is_none());
        assert_eq!(*s.get::<f32>(7).unwrap(), 1.5);
        s.insert(7, Arc::new(2.5f32), 8);
        assert_eq!((s.len(), s.resident_bytes()), (1, 8), "replacing an item replaces its bytes");
    }
}
