//! The one owner of every planner's working memory: one boxed slice (a slab) per element type
//! the planners' storage types are made of, each as long as the most that any planner's
//! entry of [`super::table::PLANNERS`] takes of it. A run cuts its planner's slices off the
//! front of the slabs ([`Cut`]): no allocation and no clearing, since every planner writes
//! what it reads. Memory: the largest planner's storage (element type by element type), not
//! the sum of all of theirs.

use crate::models::DOF;
use omcbsa_core::baselines::CompositeNode;
use omcbsa_core::cbs::CtNode;
use omcbsa_core::search::{Node, OpenEntry, PointConstraint, Slot, StartIk};

/// A slab shorter than a planner's storage asked for: the arena was measured for other
/// capacities or a shorter horizon.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Short {
    /// The slab.
    pub slab: &'static str,
    /// Elements asked for.
    pub wanted: usize,
    /// Elements left.
    pub left: usize,
}

impl std::fmt::Display for Short {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the arena's {} slab has {} elements left, {} wanted",
            self.slab, self.left, self.wanted
        )
    }
}

/// One slab as a run cuts it: what is left, and how much was taken.
struct Part<'a, T> {
    rest: &'a mut [T],
    taken: usize,
}

impl<'a, T> Part<'a, T> {
    fn take(
        &mut self,
        n: usize,
        slab: &'static str,
        measuring: bool,
    ) -> Result<&'a mut [T], Short> {
        self.taken += n;
        if measuring {
            return Ok(&mut []);
        }
        let left = self.rest.len();
        if n > left {
            return Err(Short {
                slab,
                wanted: n,
                left,
            });
        }
        let (head, tail) = core::mem::take(&mut self.rest).split_at_mut(n);
        self.rest = tail;
        Ok(head)
    }
}

/// A planner's storage cuts slices of element type `T` off the arena.
pub trait Take<'a, T> {
    /// The next `n` elements of `T`'s slab (measuring: none, but counted).
    fn take(&mut self, n: usize) -> Result<&'a mut [T], Short>;
}

/// The slabs: `name: element type = what a new slab is filled with`. A planner whose storage
/// holds a new element type adds a line here.
macro_rules! slabs {
    ($($name:ident: $t:ty = $fill:expr,)*) => {
        /// Every planner's working memory (see the module).
        pub struct Arena {
            $($name: Box<[$t]>,)*
        }

        /// Elements of each slab, taken by a run or held by an arena.
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
        pub struct Lengths {
            $(pub $name: usize,)*
        }

        impl Lengths {
            /// Slab by slab, the larger of `self` and `other`.
            pub fn max(self, other: Lengths) -> Lengths {
                Lengths { $($name: self.$name.max(other.$name),)* }
            }
        }

        impl Arena {
            /// Slabs of `len` elements each (allocated and filled here, once).
            pub fn new(len: Lengths) -> Self {
                Arena { $($name: vec![$fill; len.$name].into_boxed_slice(),)* }
            }

            /// The whole arena, to be cut for one run.
            pub fn cut(&mut self) -> Cut<'_> {
                Cut {
                    measuring: false,
                    $($name: Part { rest: &mut self.$name, taken: 0 },)*
                }
            }
        }

        /// The slabs' parts not yet taken in one run; or, measuring, a count of what a run
        /// takes and nothing handed out.
        pub struct Cut<'a> {
            measuring: bool,
            $($name: Part<'a, $t>,)*
        }

        impl Cut<'_> {
            /// A cut that hands out empty slices and counts what it was asked for.
            pub fn measuring() -> Self {
                Cut {
                    measuring: true,
                    $($name: Part { rest: &mut [], taken: 0 },)*
                }
            }

            /// Elements taken so far, slab by slab.
            pub fn taken(&self) -> Lengths {
                Lengths { $($name: self.$name.taken,)* }
            }
        }

        $(
            impl<'a> Take<'a, $t> for Cut<'a> {
                fn take(&mut self, n: usize) -> Result<&'a mut [$t], Short> {
                    self.$name.take(n, stringify!($name), self.measuring)
                }
            }
        )*
    };
}

const NO_POINT: PointConstraint = PointConstraint {
    t: 0,
    segment: false,
    s: 0.0,
    p: [0.0; 3],
    margin: 0.0,
};

slabs! {
    configurations: [f64; DOF] = [0.0; DOF],
    search_nodes: Node<DOF> = Node::default(),
    open_entries: OpenEntry = OpenEntry::default(),
    table_slots: Slot = Slot::default(),
    ct_nodes: CtNode = CtNode::default(),
    points: PointConstraint = NO_POINT,
    starts: StartIk<DOF> = StartIk::Unknown,
    composite_nodes: CompositeNode<DOF> = CompositeNode::default(),
    reals: f64 = 0.0,
    u16s: u16 = 0,
    u32s: u32 = 0,
}
