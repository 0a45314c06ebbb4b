//! The names a model declares, each bound to what it names.
//!
//! Every name is stored once, in the [`Named`] list of its kind (the lists the [`Model`] keeps).
//! The table that finds a name holds 8-byte slots, at most 7/8 full: 32 bits of the name's hash
//! and a handle (kind and index) to its entry. A `HashMap<String, (Entity, Span)>` kept a second
//! copy of every name, with an allocation each, in 80-byte buckets.
//!
//! [`Model`]: crate::Model

use std::collections::hash_map::RandomState;
use std::hash::BuildHasher;

use cordis_core::{LinkId, MatId};

use crate::error::Span;
use crate::model::Named;

/// What a name stands for.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Entity {
    Mat(MatId),
    Link(LinkId),
    Force,
    Output,
    /// A generator or device (`string`, `membrane`, `sticking device`): not a module itself.
    Group(&'static str),
}

/// What a new name is declared as.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Decl {
    Mat,
    Link,
    Force,
    Output,
    Group(&'static str),
}

/// A handle: the kind in the top 3 bits, the index in its list below.
const KIND_SHIFT: u32 = 29;
/// Entries of one kind: fewer than this many (the handle keeps 3 of its 32 bits for the kind).
pub(crate) const MAX_INDEX: usize = (1 << KIND_SHIFT) - 1;

/// An empty slot of the table, for a name not declared yet.
pub(crate) struct Vacancy {
    slot: usize,
    hash: u32,
}

#[derive(Clone, Copy, Default)]
struct Slot {
    /// The low 32 bits of the name's hash.
    hash: u32,
    /// `1 + (kind << KIND_SHIFT | index)`; 0 for an empty slot.
    handle: u32,
}

/// Every declared name, in one list per kind, with an open-addressing table (linear probing,
/// at most 7/8 full: the 32-bit hashes in the slots make a longer run cheap) to find them.
pub(crate) struct Names {
    pub(crate) materials: Vec<Named>,
    pub(crate) links: Vec<Named>,
    pub(crate) forces: Vec<Named>,
    pub(crate) outputs: Vec<Named>,
    groups: Vec<(Named, &'static str)>,
    slots: Vec<Slot>,
    len: usize,
    state: RandomState,
}

impl Names {
    pub(crate) fn new() -> Names {
        Names {
            materials: Vec::new(),
            links: Vec::new(),
            forces: Vec::new(),
            outputs: Vec::new(),
            groups: Vec::new(),
            slots: Vec::new(),
            len: 0,
            state: RandomState::new(),
        }
    }

    /// How many names are declared.
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Makes room for `n` more names without growing the table.
    pub(crate) fn reserve(&mut self, n: usize) {
        let want = self.len.saturating_add(n);
        if want.saturating_mul(8) > self.slots.len().saturating_mul(7) {
            self.rehash(table_size(want));
        }
    }

    fn hash(&self, name: &str) -> u32 {
        self.state.hash_one(name) as u32
    }

    fn name_of(&self, handle: u32) -> &str {
        let i = (handle & MAX_INDEX as u32) as usize;
        let list = match handle >> KIND_SHIFT {
            0 => &self.materials,
            1 => &self.links,
            2 => &self.forces,
            3 => &self.outputs,
            _ => return self.groups.get(i).map_or("", |(n, _)| &n.name),
        };
        list.get(i).map_or("", |n| &n.name)
    }

    fn entity(&self, handle: u32) -> (Entity, Span) {
        let i = (handle & MAX_INDEX as u32) as usize;
        let span = |list: &[Named]| list.get(i).map_or(Span::default(), |n| n.span);
        match handle >> KIND_SHIFT {
            0 => (Entity::Mat(MatId(i as u32)), span(&self.materials)),
            1 => (Entity::Link(LinkId(i as u32)), span(&self.links)),
            2 => (Entity::Force, span(&self.forces)),
            3 => (Entity::Output, span(&self.outputs)),
            _ => match self.groups.get(i) {
                Some((n, kind)) => (Entity::Group(kind), n.span),
                None => (Entity::Group(""), Span::default()),
            },
        }
    }

    /// The slot holding `name`, or the empty slot where it would go (the table is never full).
    fn probe(&self, name: &str, hash: u32) -> usize {
        let mask = self.slots.len() - 1;
        let mut i = hash as usize & mask;
        loop {
            let s = self.slots[i];
            if s.handle == 0 || (s.hash == hash && self.name_of(s.handle - 1) == name) {
                return i;
            }
            i = (i + 1) & mask;
        }
    }

    /// What `name` stands for and where it was declared.
    pub(crate) fn get(&self, name: &str) -> Option<(Entity, Span)> {
        if self.slots.is_empty() {
            return None;
        }
        let s = self.slots[self.probe(name, self.hash(name))];
        (s.handle != 0).then(|| self.entity(s.handle - 1))
    }

    /// Where a new `name` would go, or the span of its earlier declaration. Makes room first, so
    /// the place stays valid until [`Names::insert`], provided nothing else changes the table.
    pub(crate) fn vacancy(&mut self, name: &str) -> Result<Vacancy, Span> {
        self.reserve(1);
        let hash = self.hash(name);
        let slot = self.probe(name, hash);
        match self.slots[slot].handle {
            0 => Ok(Vacancy { slot, hash }),
            h => Err(self.entity(h - 1).1),
        }
    }

    /// Declares a name where [`Names::vacancy`] found room for it; returns its index in the list
    /// of its kind. The caller checks the budget and [`MAX_INDEX`] first.
    pub(crate) fn insert(&mut self, at: Vacancy, name: String, decl: Decl, span: Span) -> u32 {
        let named = Named { name, span };
        let (kind, index) = match decl {
            Decl::Mat => (0, push(&mut self.materials, named)),
            Decl::Link => (1, push(&mut self.links, named)),
            Decl::Force => (2, push(&mut self.forces, named)),
            Decl::Output => (3, push(&mut self.outputs, named)),
            Decl::Group(kind) => {
                self.groups.push((named, kind));
                (4, self.groups.len() - 1)
            }
        };
        self.slots[at.slot] = Slot {
            hash: at.hash,
            handle: 1 + ((kind << KIND_SHIFT) | index as u32),
        };
        self.len += 1;
        index as u32
    }

    /// The number of entries of the list `decl` goes to (the index the next one gets).
    pub(crate) fn next_index(&self, decl: Decl) -> usize {
        match decl {
            Decl::Mat => self.materials.len(),
            Decl::Link => self.links.len(),
            Decl::Force => self.forces.len(),
            Decl::Output => self.outputs.len(),
            Decl::Group(_) => self.groups.len(),
        }
    }

    /// Every declared name, in no particular order.
    pub(crate) fn iter(&self) -> impl Iterator<Item = &str> {
        self.materials
            .iter()
            .chain(&self.links)
            .chain(&self.forces)
            .chain(&self.outputs)
            .chain(self.groups.iter().map(|(n, _)| n))
            .map(|n| n.name.as_str())
    }

    fn rehash(&mut self, size: usize) {
        let old = std::mem::replace(&mut self.slots, vec![Slot::default(); size]);
        let mask = size - 1;
        for s in old.into_iter().filter(|s| s.handle != 0) {
            let mut i = s.hash as usize & mask;
            while self.slots[i].handle != 0 {
                i = (i + 1) & mask;
            }
            self.slots[i] = s;
        }
    }

    /// Gives back the room reserved for names that were never declared.
    pub(crate) fn shrink_lists(&mut self) {
        self.materials.shrink_to_fit();
        self.links.shrink_to_fit();
        self.forces.shrink_to_fit();
        self.outputs.shrink_to_fit();
    }
}

fn push(list: &mut Vec<Named>, n: Named) -> usize {
    list.push(n);
    list.len() - 1
}

/// The smallest power of two at least 16 that holds `n` names at most 7/8 full.
fn table_size(n: usize) -> usize {
    (n.saturating_mul(8) / 7 + 1).max(16).next_power_of_two()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_found_and_duplicates_refused() {
        let mut names = Names::new();
        let span = |line| Span {
            line,
            ..Span::default()
        };
        let declare = |names: &mut Names, name: String, decl, line| {
            let at = names.vacancy(&name)?;
            Ok::<_, Span>(names.insert(at, name, decl, span(line)))
        };
        for i in 0..1000 {
            assert_eq!(
                declare(&mut names, format!("m{i}"), Decl::Mat, i),
                Ok(i as u32)
            );
            assert_eq!(
                declare(&mut names, format!("l{i}"), Decl::Link, i),
                Ok(i as u32)
            );
        }
        assert_eq!(
            declare(&mut names, "s".into(), Decl::Group("string"), 7),
            Ok(0)
        );
        assert_eq!(declare(&mut names, "out".into(), Decl::Output, 8), Ok(0));
        assert_eq!(names.len(), 2002);
        assert!(matches!(names.get("m517"), Some((Entity::Mat(MatId(517)), s)) if s.line == 517));
        assert!(matches!(
            names.get("l3"),
            Some((Entity::Link(LinkId(3)), _))
        ));
        assert!(matches!(names.get("s"), Some((Entity::Group("string"), _))));
        assert!(matches!(names.get("out"), Some((Entity::Output, _))));
        assert!(names.get("m1000").is_none());
        assert_eq!(
            declare(&mut names, "m5".into(), Decl::Link, 99),
            Err(span(5))
        );
        assert_eq!(names.len(), 2002);
        assert_eq!(names.links.len(), 1000);
        assert_eq!(names.iter().count(), 2002);
    }
}
