//! What a check found wrong: one typed record per problem, naming the tile (path in the tree and
//! content uri) and, where it applies, the node (building index, or block level and node index).
//! Units: metres for errors, pixels for screen measures. Every check reports all problems it sees.

use serde::Serialize;

use crate::tileset::{LoadedTileset, NodeRef};

/// The kinds of problem the checker knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FindingKind {
    /// A building of the tileset is not covered by the cut (a hole).
    BuildingMissing,
    /// A building is covered twice by the cut (drawn twice, or drawn and culled twice).
    BuildingTwice,
    /// The same building index appears in two leaf tiles.
    BuildingInTwoLeaves,
    /// A block tile's Σ member_count differs from what its children hold (a block or a child lost).
    MemberCountMismatch,
    /// A feature carries no identity the checker understands (no building_index, level/node_index).
    UnknownFeature,
    /// A child tile has a larger geometricError than its parent.
    ErrorGrows,
    /// A selected block shows a height error ΔH_view above δH.
    HeightCriterion,
    /// A selected block shows an added area ΔA_view above δA.
    AreaCriterion,
    /// A selected tile has no content: it draws nothing where buildings should be.
    EmptyTileSelected,
    /// A child link points outside the tile list or back to a visited tile.
    BadLink,
    /// The tileset's geometricError is so small that a client draws nothing from this view.
    TilesetNotDrawn,
    /// The skyline of the cut moved more than δH plus the tolerance from full detail's.
    SkylineShift,
    /// A tile draws vertices outside its own bounding box or an ancestor's: a client culling that box loses them.
    ContentOutsideVolume,
    /// A feature of a tile's property table draws no triangle with any area: the buildings it stands for count as
    /// covered but are not drawn.
    FeatureDrawsNothing,
    /// A building of the leaves that a tile above them does not draw at all, though it is too large for the tile's
    /// geometricError to let it vanish.
    BuildingVanishes,
    /// A block drawn otherwise than its metadata says (its ground and height), or whose heights contradict each other.
    BlockMisdrawn,
    /// What a tile draws lies farther from full detail than it declares: a block's Δh below what its buildings
    /// measure, or a building drawn above its leaf farther from its leaf geometry than the tile's geometricError.
    ErrorUnderstated,
}

/// One problem.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Finding {
    pub kind: FindingKind,
    /// The tile's path in the tree (`0/2/1`); empty when the finding concerns no single tile.
    pub tile: String,
    /// The tile's content uri, when it has one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub content_uri: Option<String>,
    /// The node concerned, when one is.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub node: Option<NodeRef>,
    /// The value measured (unit in `message`) and the limit it broke, when numeric.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub measured: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub limit: Option<f64>,
    /// Building indices concerned (at most [`MAX_LISTED`]; `message` gives the full count).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub buildings: Vec<u32>,
    pub message: String,
}

/// Most building indices listed in one finding.
pub const MAX_LISTED: usize = 20;

impl Finding {
    /// A finding about tile `i` of `ts` (no node, no numbers yet).
    pub(crate) fn at(kind: FindingKind, ts: &LoadedTileset, i: usize, message: String) -> Finding {
        let t = ts.tiles.get(i);
        Finding {
            kind,
            tile: t.map(|t| t.path_in_tree.clone()).unwrap_or_default(),
            content_uri: t.and_then(|t| t.content_uri.clone()),
            node: None,
            measured: None,
            limit: None,
            buildings: Vec::new(),
            message,
        }
    }

    pub(crate) fn node(mut self, node: NodeRef) -> Finding {
        self.node = Some(node);
        self
    }

    pub(crate) fn values(mut self, measured: f64, limit: f64) -> Finding {
        self.measured = Some(measured);
        self.limit = Some(limit);
        self
    }

    pub(crate) fn buildings(mut self, b: &[u32]) -> Finding {
        self.buildings = b.iter().copied().take(MAX_LISTED).collect();
        self
    }
}
