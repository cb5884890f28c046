//! One memory budget per scene load: the bytes of every file, buffer,
//! decoded image and instance transform a load holds are taken from it
//! before they are allocated. A manifest shares its budget with every glTF
//! file it names, so naming one large file many times, or many entries,
//! cannot multiply memory.

use std::cell::Cell;

/// Most bytes one scene load (a glTF file, or a manifest and everything it
/// names) may hold.
pub const MAX_SCENE_LOAD_BYTES: u64 = 8 << 30;

/// What is left of one load's budget.
#[derive(Debug)]
pub struct LoadBudget {
    total: u64,
    left: Cell<u64>,
}

impl Default for LoadBudget {
    fn default() -> Self {
        LoadBudget::new(MAX_SCENE_LOAD_BYTES)
    }
}

impl LoadBudget {
    /// A budget of `total` bytes.
    pub fn new(total: u64) -> LoadBudget {
        LoadBudget {
            total,
            left: Cell::new(total),
        }
    }

    /// Bytes still allowed.
    pub fn left(&self) -> u64 {
        self.left.get()
    }

    /// Takes `bytes` for `what`, or says (naming `what`) that they would
    /// exceed the budget. `None` (a size that overflowed) always fails.
    pub fn spend(&self, bytes: Option<u64>, what: &str) -> Result<(), String> {
        let left = self.left.get();
        match bytes {
            Some(b) if b <= left => {
                self.left.set(left - b);
                Ok(())
            }
            Some(b) => Err(format!(
                "{what}: {b} more bytes would exceed the {}-byte memory budget of one scene load ({} left)",
                self.total, left
            )),
            None => Err(format!(
                "{what}: its size overflows; the memory budget of one scene load is {} bytes",
                self.total
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spending_is_shared_and_bounded() {
        let b = LoadBudget::new(100);
        b.spend(Some(60), "a").unwrap();
        let e = b.spend(Some(41), "b").unwrap_err();
        assert!(
            e.contains("b: 41 more bytes") && e.contains("(40 left)"),
            "{e}"
        );
        b.spend(Some(40), "c").unwrap();
        assert_eq!(b.left(), 0);
        assert!(b.spend(None, "d").unwrap_err().contains("overflows"));
    }
}
