//! What a synthetic scene is made of: the targets' shape, the clutter, the
//! layout, the sensor and the map's distortion, as read from a TOML file.

use super::*;

/// The build of one L-target (defaults: the paper's hardware).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TargetShape {
    /// Plate width (horizontal), metres.
    pub plate_width_m: f64,
    /// Plate height, metres.
    pub plate_height_m: f64,
    /// Height of the plates' bottom edge above the ground at the corner, metres.
    pub plate_bottom_m: f64,
    /// Side of the square corner post (aluminium extrusion), metres.
    pub post_m: f64,
    /// Post length above the plates' top edge, below the antenna, metres.
    pub post_above_m: f64,
    /// GNSS antenna radius, metres.
    pub antenna_radius_m: f64,
    /// GNSS antenna height, metres.
    pub antenna_height_m: f64,
    /// Grill mesh hole pitch, metres.
    pub mesh_pitch_m: f64,
    /// Grill mesh hole side (pitch 0.04, hole 0.028 → about half open), metres.
    pub mesh_hole_m: f64,
    /// Solid frame around the mesh, metres.
    pub frame_m: f64,
}

impl Default for TargetShape {
    fn default() -> Self {
        TargetShape {
            plate_width_m: 0.6,
            plate_height_m: 0.6,
            plate_bottom_m: 0.8,
            post_m: 0.03,
            post_above_m: 0.05,
            antenna_radius_m: 0.08,
            antenna_height_m: 0.07,
            mesh_pitch_m: 0.04,
            mesh_hole_m: 0.028,
            frame_m: 0.02,
        }
    }
}

/// Clutter, and the hard cases that defeat a naive locator.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ClutterParams {
    /// Number of poles placed at random (at least 4 m from any target).
    pub poles: usize,
    /// Number of bushes placed at random.
    pub bushes: usize,
    /// Number of parked cars beside the road.
    pub cars: usize,
    /// A building façade (40 m long, 6 m high) 36 m off the road.
    pub wall: bool,
    /// Hard case: a pole and a utility cabinet this far (nearest surface, metres)
    /// from target 1's corner. `None`: off.
    pub near_target_m: Option<f64>,
    /// Hard case: a bush touching a plate of target 2 (target 1 when K = 1).
    pub bush_touching: bool,
    /// Scene-wide decoys (issue 15): objects a map-wide detector could take
    /// for a target, placed along the road at the targets' distances from it
    /// (`target_distance_m`), every part at least 4 m from every target's
    /// corner, off the road, and out of the 45° cone between each target and
    /// the road so none hides a target. In turn: a building corner, an
    /// L-shaped board of 0.9–1.2 m arms, a utility cabinet, a small L of
    /// 0.35–0.45 m arms, a pallet stack (see [`DecoyTruth`]). They draw from
    /// their own random stream, so targets and other clutter do not move;
    /// when the scene has no room for one it is left out (truth.json lists
    /// those placed). 0 (default): none, and truth.json has no `decoys`.
    ///
    /// ```toml
    /// [clutter]
    /// decoys = 10
    /// ```
    #[serde(skip_serializing_if = "is_zero")]
    pub decoys: usize,
}

fn is_zero(n: &usize) -> bool {
    *n == 0
}

fn is_origin(v: &[f64; 3]) -> bool {
    *v == [0.0; 3]
}

/// How the targets are laid out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Layout {
    /// Spread along the road, alternating sides, at `target_distance_m`.
    #[default]
    Road,
    /// Four targets at the corners of a square of side `spread_m` (16–60 m),
    /// its sides parallel to the road's ends, centred on the road's middle so
    /// the road passes through it; every L opens towards the centre (heading =
    /// direction from the centre + 135°), so the layout maps onto itself under
    /// a 90° rotation about the centre: an ambiguous layout for frame matching.
    /// Corner k (id k + 1) is at direction 45° + 90°·k from the centre. For
    /// equal corner heights too, set `slope_deg = 0` and `undulation_m = 0`.
    /// Corners lie side/2 (± the road's curve) off the road, so a side of up
    /// to ~30 m keeps them at the targets' usual distances; a 60 m square
    /// puts them ~30 m off, with about a quarter of the returns. Ignores
    /// `target_distance_m`.
    Square,
}

impl Layout {
    fn is_road(&self) -> bool {
        *self == Layout::Road
    }
}

impl Default for ClutterParams {
    fn default() -> Self {
        ClutterParams {
            poles: 8,
            bushes: 6,
            cars: 2,
            wall: true,
            near_target_m: None,
            bush_touching: false,
            decoys: 0,
        }
    }
}

/// Everything that defines a synthetic scene. Same parameters → same bytes.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SynthParams {
    /// Seed of every random choice.
    pub seed: u64,
    /// Approximate number of map points (sets the number of scans).
    pub points: u64,
    /// Number of targets K (ids "1".."K").
    pub targets: usize,
    /// Distance along the road over which the targets are spread, metres.
    pub spread_m: f64,
    /// Range of the targets' lateral distance from the road, metres.
    pub target_distance_m: [f64; 2],
    /// The target build.
    pub target: TargetShape,
    /// Ground slope, degrees.
    pub slope_deg: f64,
    /// Direction of steepest ascent, degrees from +x.
    pub slope_dir_deg: f64,
    /// Undulation: bound on the bumps' amplitude, metres (wavelengths 6–25 m).
    pub undulation_m: f64,
    /// Sideways amplitude of the road's curve, metres.
    pub road_curve_m: f64,
    /// Clutter and hard cases.
    pub clutter: ClutterParams,
    /// Obstacles around target 1 (issue 16's field cases); all off by default
    /// and then left out of truth.json, so existing scenes keep their bytes.
    #[serde(skip_serializing_if = "ObstacleParams::is_off")]
    pub obstacles: ObstacleParams,
    /// The sensor.
    pub lidar: LidarParams,
    /// World → map distortion.
    pub distortion: DistortParams,
    /// 1σ noise added to the surveyed positions (x, y, z), metres.
    pub survey_noise_m: f64,
    /// Geodetic origin (lat°, lon°, ellipsoidal height m) of the local ENU world
    /// frame, for writing the survey in WGS84.
    pub origin_llh: [f64; 3],
    /// False origin of the survey frame, metres: the scene is built in a local
    /// frame L and the survey (world) frame is L + this, so [352000, 4026000, 0]
    /// gives a UTM-size survey while the map stays where it was. It is added
    /// to survey.csv and to every position in truth.json except the scene's
    /// model parameters (see [`Truth`]); survey_llh.csv is unchanged (it is
    /// the same physical points). Default [0, 0, 0], then left out of the
    /// printed config and truth.json.
    ///
    /// ```toml
    /// survey_false_origin_m = [352000.0, 4026000.0, 0.0]
    /// ```
    #[serde(skip_serializing_if = "is_origin")]
    pub survey_false_origin_m: [f64; 3],
    /// Target layout: "road" (default) or "square" (see [`Layout`]).
    ///
    /// ```toml
    /// layout = "square"
    /// targets = 4
    /// spread_m = 30.0
    /// slope_deg = 0.0
    /// undulation_m = 0.0
    /// ```
    #[serde(skip_serializing_if = "Layout::is_road")]
    pub layout: Layout,
    /// A second pass over the end of the road that the map did not merge
    /// with the first (a loop closed badly): every object there is mapped
    /// twice. Off by default, and then absent from the printed config and
    /// truth.json.
    ///
    /// ```toml
    /// [second_pass]
    /// share = 0.5             # the last half of the road is driven again
    /// offset_m = [0.05, -0.04, 0.0]
    /// ```
    #[serde(skip_serializing_if = "SecondPass::is_off")]
    pub second_pass: SecondPass,
    /// The targets' models in turn: target i is `models[i % len]` (`l`,
    /// `sphere`, `board`). The L alone by default, and then absent from the printed
    /// config and truth.json.
    ///
    /// ```toml
    /// models = ["l", "sphere"]
    /// [sphere]
    /// diameter_m = 0.145
    /// ```
    #[serde(skip_serializing_if = "only_l")]
    pub models: Vec<crate::model::ModelKind>,
    /// How sphere targets are built.
    #[serde(skip_serializing_if = "no_spheres_default")]
    pub sphere: SphereShape,
    /// How checkerboard boards are built and print in the map's intensity.
    #[serde(skip_serializing_if = "no_boards_default")]
    pub board: BoardShape,
}

fn no_boards_default(b: &BoardShape) -> bool {
    *b == BoardShape::default()
}

/// A checkerboard board: a square of four squares (two bright, two dark)
/// standing upright on two legs, its face towards the road. Its returns'
/// intensity is the print's, blurred by the beam's footprint; the survey
/// gives the point where the squares meet, on the face.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoardShape {
    /// Side, metres.
    pub side_m: f64,
    /// Height of the centre above the ground, metres.
    pub centre_height_m: f64,
    /// Turn of the print in the face (degrees; 0: the squares upright).
    pub print_turn_deg: f64,
    /// Intensity of the dark and of the bright squares (the map's scale).
    pub levels: [f64; 2],
    /// 1-σ of the beam's footprint on the face (m): it mixes the squares'
    /// intensities at their edges.
    pub footprint_m: f64,
    /// With a value, a plain sign of the board's size and height (one
    /// intensity, the levels' mean) stands beside each board on legs of its
    /// own, in the board's plane, this far (m) from its edge: the hard case
    /// of a flat thing of the right size. Part of the target's object.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sign_gap_m: Option<f64>,
    /// Lying face up on the ground (2 cm thick, level, resting on the
    /// ground's highest point under it), as UAV ground-control boards lie,
    /// instead of standing on legs; `centre_height_m` is then unused and the
    /// print's first axis runs along the road. A sign beside it lies flat too.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub flat: bool,
    /// With a value, a wall (3 m wide, 2.5 m tall, plain) stands behind each
    /// standing board, its face this far (m) behind the board's back: a
    /// board hung on a wall, whose face alone is no board's (-0.02, the
    /// board's thickness: the wall's face flush with the board's, as a
    /// print on the wall is).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wall_gap_m: Option<f64>,
}

impl Default for BoardShape {
    fn default() -> Self {
        BoardShape {
            side_m: 0.6,
            centre_height_m: 1.2,
            print_turn_deg: 0.0,
            levels: [15.0, 200.0],
            footprint_m: 0.004,
            sign_gap_m: None,
            flat: false,
            wall_gap_m: None,
        }
    }
}

fn only_l(m: &[crate::model::ModelKind]) -> bool {
    m.iter().all(|k| *k == crate::model::ModelKind::L)
}

fn no_spheres_default(s: &SphereShape) -> bool {
    *s == SphereShape::default()
}

/// A sphere target: a sphere on a thin pole standing on the ground.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SphereShape {
    /// Diameter, metres.
    pub diameter_m: f64,
    /// Height of the centre above the ground, metres.
    pub centre_height_m: f64,
    /// Radius of the pole under it, metres.
    pub pole_radius_m: f64,
    /// With a value, the sphere is held by a magnetic nest to a wall panel
    /// (0.6 m square, 2 cm thick, on its own post) behind it, away from
    /// the road, this far (m) from the sphere's surface, as spheres are
    /// mounted on walls and steelwork; without, it stands on its pole. The
    /// panel is part of the target's object: its returns count as the
    /// target's in truth.json's `points` and in `--labels`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wall_gap_m: Option<f64>,
}

impl Default for SphereShape {
    fn default() -> Self {
        SphereShape {
            diameter_m: 0.145,
            centre_height_m: 1.3,
            pole_radius_m: 0.015,
            wall_gap_m: None,
        }
    }
}

/// The end of the road driven again, its points landing `offset_m` from
/// the first pass's: the seam a badly closed loop leaves (issue 30).
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SecondPass {
    /// Share of the road, from its end, driven a second time (0: none).
    pub share: f64,
    /// Displacement of the second pass's points from the first's, map
    /// frame, metres: the drift the loop closure left.
    pub offset_m: [f64; 3],
}

impl SecondPass {
    /// No second pass (the truth file then omits the section).
    pub(crate) fn is_off(&self) -> bool {
        self.share == 0.0
    }
}

impl Default for SynthParams {
    fn default() -> Self {
        SynthParams {
            seed: 1,
            points: 2_000_000,
            targets: 5,
            spread_m: 100.0,
            target_distance_m: [5.0, 15.0],
            target: TargetShape::default(),
            models: vec![crate::model::ModelKind::L],
            sphere: SphereShape::default(),
            board: BoardShape::default(),
            slope_deg: 1.5,
            slope_dir_deg: 30.0,
            undulation_m: 0.08,
            road_curve_m: 3.0,
            clutter: ClutterParams::default(),
            obstacles: ObstacleParams::default(),
            lidar: LidarParams::default(),
            distortion: DistortParams::default(),
            survey_noise_m: 0.0,
            origin_llh: [36.3725, 127.3631, 70.0],
            survey_false_origin_m: [0.0; 3],
            layout: Layout::Road,
            second_pass: SecondPass::default(),
        }
    }
}

impl SynthParams {
    /// Checks every value, naming the first bad one.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: &str| Err(Error::Param(m.to_string()));
        if self.points == 0 || self.points > 100_000_000_000 {
            return bad("points must be in 1..=1e11");
        }
        if self.targets == 0 || self.targets > 1000 {
            return bad("targets must be in 1..=1000");
        }
        if self.models.is_empty() {
            return bad("models must name at least one model (l, sphere, board)");
        }
        let b = &self.board;
        if let Err(e) = crate::model::ModelKind::Board.check_size(b.side_m) {
            return Err(Error::Param(format!("board.side_m: {e}")));
        }
        if !(b.centre_height_m >= 0.6 * b.side_m && b.centre_height_m <= 5.0) {
            return bad("board.centre_height_m must be in [0.6 side_m, 5]");
        }
        if !(b
            .levels
            .iter()
            .all(|l| l.is_finite() && (0.0..=65535.0).contains(l)))
        {
            return bad("board.levels must be in [0, 65535]");
        }
        if !(0.0..=0.05).contains(&b.footprint_m) {
            return bad("board.footprint_m must be in [0, 0.05]");
        }
        if b.sign_gap_m.is_some_and(|g| !(0.05..=5.0).contains(&g)) {
            return bad("board.sign_gap_m must be in [0.05, 5]");
        }
        if b.wall_gap_m.is_some_and(|g| !(-0.02..=0.2).contains(&g)) {
            return bad("board.wall_gap_m must be in [-0.02, 0.2]");
        }
        if !b.print_turn_deg.is_finite() {
            return bad("board.print_turn_deg must be finite");
        }
        let sp = &self.sphere;
        if let Err(e) = crate::model::ModelKind::Sphere.check_size(sp.diameter_m) {
            return Err(Error::Param(format!("sphere.diameter_m: {e}")));
        }
        if !(sp.centre_height_m >= sp.diameter_m && sp.centre_height_m <= 5.0) {
            return bad("sphere.centre_height_m must be in [diameter_m, 5]");
        }
        if !(sp.pole_radius_m > 0.0 && sp.pole_radius_m < 0.4 * sp.diameter_m) {
            return bad("sphere.pole_radius_m must be in (0, 0.4 diameter_m)");
        }
        if sp.wall_gap_m.is_some_and(|g| !(0.0..=0.2).contains(&g)) {
            return bad("sphere.wall_gap_m must be in [0, 0.2]");
        }
        if !(self.spread_m >= 0.0 && self.spread_m <= 10_000.0) {
            return bad("spread_m must be in [0, 10000]");
        }
        let [d0, d1] = self.target_distance_m;
        if !(d0 >= 2.0 && d1 >= d0 && d1 <= 90.0) {
            return bad("target_distance_m = [min, max] with 2 <= min <= max <= 90");
        }
        if !(self.slope_deg.abs() <= 20.0 && self.slope_dir_deg.is_finite()) {
            return bad("|slope_deg| must be <= 20");
        }
        if !(self.undulation_m >= 0.0 && self.undulation_m <= 2.0) {
            return bad("undulation_m must be in [0, 2]");
        }
        if !self.road_curve_m.is_finite() || self.road_curve_m.abs() > 50.0 {
            return bad("|road_curve_m| must be <= 50");
        }
        if !(self.survey_noise_m >= 0.0 && self.survey_noise_m <= 1.0) {
            return bad("survey_noise_m must be in [0, 1]");
        }
        if self.survey_false_origin_m.iter().any(|v| !(v.abs() <= 1e8)) {
            return bad("survey_false_origin_m values must be finite, |v| <= 1e8");
        }
        if self.layout == Layout::Square {
            if self.targets != 4 {
                return bad("layout = \"square\" needs targets = 4");
            }
            if !(10.0..=60.0).contains(&self.spread_m) {
                return bad(
                    "layout = \"square\": spread_m (the square's side) must be in [10, 60]",
                );
            }
        }
        let [lat, lon, hgt] = self.origin_llh;
        if !(lat.abs() <= 89.0 && lon.abs() <= 180.0 && hgt.abs() <= 10_000.0) {
            return bad("origin_llh = [lat, lon, h] with |lat| <= 89, |lon| <= 180, |h| <= 10000");
        }
        let t = &self.target;
        let pos = [
            t.plate_width_m,
            t.plate_height_m,
            t.post_m,
            t.antenna_radius_m,
            t.antenna_height_m,
            t.mesh_pitch_m,
        ];
        if pos.iter().any(|v| !(*v > 0.0 && *v <= 10.0)) {
            return bad("target sizes must be in (0, 10] m");
        }
        if !(t.plate_bottom_m >= 0.0 && t.plate_bottom_m <= 10.0 && t.post_above_m >= 0.0) {
            return bad("target.plate_bottom_m must be in [0, 10], post_above_m >= 0");
        }
        if !(t.mesh_hole_m >= 0.0 && t.mesh_hole_m < t.mesh_pitch_m) {
            return bad("target.mesh_hole_m must be in [0, mesh_pitch_m)");
        }
        if !(t.frame_m >= 0.0 && 2.0 * t.frame_m <= t.plate_width_m.min(t.plate_height_m)) {
            return bad("target.frame_m must be in [0, plate size / 2]");
        }
        let c = &self.clutter;
        if c.poles > 10_000 || c.bushes > 10_000 || c.cars > 10_000 {
            return bad("clutter counts must be <= 10000");
        }
        // Placement checks every decoy against those placed: quadratic.
        if c.decoys > 200 {
            return bad("clutter.decoys must be <= 200");
        }
        if let Some(d) = c.near_target_m
            && !(0.0..=20.0).contains(&d)
        {
            return bad("clutter.near_target_m must be in [0, 20]");
        }
        let sp = &self.second_pass;
        if !(0.0..=1.0).contains(&sp.share) || sp.offset_m.iter().any(|v| !(v.abs() <= 10.0)) {
            return bad("second_pass: share in [0, 1], |offset_m| <= 10 m");
        }
        self.obstacles.validate()?;
        self.lidar.validate()?;
        self.distortion.validate()?;
        if self.layout == Layout::Square {
            scene::square_layout(self, &scene::road_of(self))
                .map(|_| ())
                .map_err(Error::Param)?;
        }
        Ok(())
    }
}
