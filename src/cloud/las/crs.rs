//! The coordinate reference system a LAS/LAZ/COPC header declares (a
//! `LASF_Projection` record: OGC WKT, 1 or 2, or GeoTIFF keys), read for
//! what mapgauge must know of it: whether the map is georeferenced (its z
//! vertical by construction), and whether its coordinates are metres at all
//! (degrees of a geographic CRS, feet of a State Plane one).

use std::path::Path;

/// A header's Earth CRS as mapgauge needs it.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Crs {
    /// For a user: `EPSG:32633`, or the WKT's name.
    pub name: String,
    /// Its x and y are longitude and latitude (degrees), as the header's
    /// bounds agree (a header can be wrong: PDAL's lone-star.laz names
    /// EPSG:4326 over UTM coordinates).
    pub degrees: bool,
    /// The middle of the header's x, y bounds.
    pub middle: [f64; 2],
    /// The horizontal length unit other than the metre: name and metres.
    pub horizontal_unit: Option<(String, f64)>,
    /// The vertical length unit, when a vertical CRS declares one (the
    /// metre too: heights in metres under x and y in feet are a case of
    /// their own).
    pub vertical_unit: Option<(String, f64)>,
}

/// The CRS named for a user when the header declares an Earth one; `None`
/// when it declares none, only a local or engineering one (a SLAM map's own
/// frame written with a CRS record), an Earth-centred one (x, y, z about the
/// Earth's centre: z is not up), or the header cannot be read (the points'
/// reader says why).
pub(crate) fn declared_crs(path: &Path) -> Option<String> {
    crs_of(path).map(|c| c.name)
}

/// The header's Earth CRS, read as [`Crs`].
pub(crate) fn crs_of(path: &Path) -> Option<Crs> {
    let h = &header_of(path)?;
    let b = h.bounds();
    let middle = [(b.min.x + b.max.x) / 2.0, (b.min.y + b.max.y) / 2.0];
    // Degrees only where the bounds read as such too: within longitude and
    // latitude, and a site's extent (under a degree, 111 km).
    let could_be_degrees = middle[0].abs() <= 180.0
        && middle[1].abs() <= 90.0
        && b.max.x - b.min.x <= 1.0
        && b.max.y - b.min.y <= 1.0;
    let mut crs = match h.get_wkt_crs_bytes() {
        Some(wkt) => from_wkt(&String::from_utf8_lossy(wkt))?,
        None => from_geotiff(&h.get_geotiff_crs().ok()??)?,
    };
    crs.degrees &= could_be_degrees;
    crs.middle = middle;
    Some(crs)
}

/// The header and its records, read without the points: no LAZ decoder is
/// made (a malformed chunk table asked for 25 GB: fuzz find), and an
/// extended record's length is held against the file's size before `las`
/// reads it into memory. `None` where the header cannot be read: the
/// points' reader, run before or after, says why.
fn header_of(path: &Path) -> Option<las::Header> {
    use std::io::{BufReader, Read, Seek, SeekFrom};
    let file = std::fs::File::open(path).ok()?;
    let size = file.metadata().ok()?.len();
    let mut f = BufReader::new(file);
    let raw = las::raw::Header::read_from(&mut f).ok()?;
    if let Some(e) = raw.evlr {
        // An EVLR's header is 60 bytes, its length a u64 at byte 20.
        let start = e.start_of_first_evlr;
        if start.checked_add(60)? > size {
            return None;
        }
        f.seek(SeekFrom::Start(start + 20)).ok()?;
        let mut len = [0u8; 8];
        f.read_exact(&mut len).ok()?;
        if (start + 60).checked_add(u64::from_le_bytes(len))? > size {
            return None;
        }
    }
    f.seek(SeekFrom::Start(0)).ok()?;
    las::Header::new(f).ok()
}

fn from_geotiff(keys: &las::crs::GeoTiffCrs) -> Option<Crs> {
    // An EPSG code names it; user-defined (32767) and omitted (0) do not,
    // but a model type of projected (1) or geographic (2) still says the
    // frame is the Earth's. Degrees: a geographic model, or no model and a
    // geodetic code without any projected key (a model type of 3,
    // Earth-centred, is taken at its code: real files carry it over
    // projected coordinates).
    let known = |c: Option<u16>| c.filter(|&c| c != 0 && c != 32767);
    let projected_key = keys.get_projected_crs_geo_key_value();
    let projected = known(projected_key);
    let geodetic = known(keys.get_geodetic_crs_geo_key_value());
    let model = keys.get_gt_model_type_geo_key_value();
    let degrees =
        model == Some(2) || (model.is_none() && projected_key.is_none() && geodetic.is_some());
    let name = if let Some(c) = projected {
        format!("EPSG:{c}")
    } else if projected_key == Some(32767) || model == Some(1) {
        "a user-defined projected CRS".into()
    } else if let Some(c) = geodetic {
        format!("EPSG:{c}")
    } else if model == Some(2) {
        "a user-defined geographic CRS".into()
    } else {
        return None;
    };
    // ProjLinearUnitsGeoKey (x, y of a projected CRS) and
    // VerticalUnitsGeoKey: EPSG unit codes.
    let unit = |id: u16| {
        keys.entries
            .iter()
            .find(|k| k.id == id)
            .and_then(|k| match k.data {
                las::crs::GeoTiffData::U16(c) => epsg_length_unit(c),
                _ => None,
            })
    };
    Some(Crs {
        name,
        degrees,
        middle: [0.0; 2],
        horizontal_unit: if degrees {
            None
        } else {
            unit(3076).filter(|u| u.1 != 1.0)
        },
        vertical_unit: unit(4099),
    })
}

/// The EPSG length units a LAS header names.
fn epsg_length_unit(code: u16) -> Option<(String, f64)> {
    let (name, m) = match code {
        9001 => ("metre", 1.0),
        9002 => ("foot", 0.3048),
        9003 => ("US survey foot", 1200.0 / 3937.0),
        9005 => ("Clarke's foot", 0.3047972654),
        9036 => ("kilometre", 1000.0),
        _ => return None,
    };
    Some((name.to_string(), m))
}

fn from_wkt(wkt: &str) -> Option<Crs> {
    let t = Wkt::parse(wkt);
    let first = t.first_crs()?;
    let key = t.nodes[first].key.as_str();
    let degrees = match key {
        "PROJCS" | "PROJCRS" | "PROJECTEDCRS" => false,
        "GEOGCS" | "GEOGCRS" | "GEOGRAPHICCRS" => true,
        // WKT 2's geodetic CRS is geographic with an ellipsoidal
        // coordinate system, Earth-centred with a Cartesian one.
        "GEODCRS" | "GEODETICCRS" => {
            let cartesian = t.children(first).any(|c| {
                t.nodes[c].key == "CS"
                    && t.nodes[c]
                        .words
                        .first()
                        .is_some_and(|w| w.eq_ignore_ascii_case("cartesian"))
            });
            if cartesian {
                return None;
            }
            true
        }
        _ => return None,
    };
    let vertical = t
        .nodes
        .iter()
        .position(|n| matches!(n.key.as_str(), "VERT_CS" | "VERTCRS" | "VERTICALCRS"));
    Some(Crs {
        name: t.name(),
        degrees,
        middle: [0.0; 2],
        horizontal_unit: if degrees {
            None
        } else {
            t.unit_of(first).filter(|u| u.1 != 1.0)
        },
        vertical_unit: vertical.and_then(|v| t.unit_of(v)),
    })
}

/// A WKT read as a tree: each `KEYWORD[…]` (or WKT 2's `KEYWORD(…)`) a
/// node with its quoted texts and bare words or numbers, in document order.
/// Quoted names are never taken for keywords, and spaces may stand
/// anywhere between tokens.
struct Wkt {
    nodes: Vec<WktNode>,
}

struct WktNode {
    /// Upper-cased keyword.
    key: String,
    children: Vec<usize>,
    texts: Vec<String>,
    /// Bare words and numbers, as written.
    words: Vec<String>,
}

impl Wkt {
    fn parse(s: &str) -> Wkt {
        let mut nodes: Vec<WktNode> = Vec::new();
        let mut stack: Vec<usize> = Vec::new();
        let mut token = String::new();
        let mut chars = s.chars().peekable();
        // A bare token ends at a delimiter: a keyword when an opening
        // bracket follows (after any spaces), else a word of the node open.
        let flush = |token: &mut String, nodes: &mut Vec<WktNode>, stack: &[usize]| {
            if !token.is_empty() {
                if let Some(&open) = stack.last() {
                    nodes[open].words.push(std::mem::take(token));
                }
                token.clear();
            }
        };
        while let Some(c) = chars.next() {
            match c {
                '[' | '(' => {
                    let at = nodes.len();
                    nodes.push(WktNode {
                        key: std::mem::take(&mut token).to_ascii_uppercase(),
                        children: Vec::new(),
                        texts: Vec::new(),
                        words: Vec::new(),
                    });
                    if let Some(&open) = stack.last() {
                        nodes[open].children.push(at);
                    }
                    stack.push(at);
                }
                ']' | ')' => {
                    flush(&mut token, &mut nodes, &stack);
                    stack.pop();
                }
                ',' => flush(&mut token, &mut nodes, &stack),
                '"' => {
                    // WKT doubles a quote inside a quoted text.
                    let mut text = String::new();
                    while let Some(q) = chars.next() {
                        if q == '"' {
                            if chars.peek() == Some(&'"') {
                                chars.next();
                                text.push('"');
                                continue;
                            }
                            break;
                        }
                        text.push(q);
                    }
                    if let Some(&open) = stack.last() {
                        nodes[open].texts.push(text);
                    }
                }
                c if c.is_whitespace() => {
                    // A keyword may be followed by spaces before its bracket.
                    let next = loop {
                        match chars.peek() {
                            Some(w) if w.is_whitespace() => {
                                chars.next();
                            }
                            other => break other.copied(),
                        }
                    };
                    if !matches!(next, Some('[' | '(')) {
                        flush(&mut token, &mut nodes, &stack);
                    }
                }
                c => token.push(c),
            }
        }
        Wkt { nodes }
    }

    fn children(&self, i: usize) -> impl Iterator<Item = usize> + '_ {
        self.nodes[i].children.iter().copied()
    }

    /// The first CRS keyword in document order: a compound or bound CRS
    /// wraps its horizontal one, and WKT 1's `PROJCS` holds its `GEOGCS`
    /// after its own keyword. `None` when that first CRS is local,
    /// engineering or Earth-centred.
    fn first_crs(&self) -> Option<usize> {
        const CRS: [&str; 14] = [
            "PROJCS",
            "PROJCRS",
            "PROJECTEDCRS",
            "GEOGCS",
            "GEOGCRS",
            "GEOGRAPHICCRS",
            "GEODCRS",
            "GEODETICCRS",
            "GEOCCS",
            "LOCAL_CS",
            "ENGCRS",
            "ENGINEERINGCRS",
            "VERT_CS",
            "VERTCRS",
        ];
        self.nodes
            .iter()
            .position(|n| CRS.contains(&n.key.as_str()))
    }

    /// The length unit of CRS node `i`: its own `UNIT`
    /// (WKT 1) or `LENGTHUNIT` (WKT 2), else its axes'. Never a unit nested
    /// deeper (a geographic base's degree, a parameter's or a
    /// transformation's scale).
    fn unit_of(&self, i: usize) -> Option<(String, f64)> {
        let unit = |n: usize| {
            self.children(n)
                .find(|&c| matches!(self.nodes[c].key.as_str(), "UNIT" | "LENGTHUNIT"))
        };
        let u = unit(i).or_else(|| {
            self.children(i)
                .filter(|&c| self.nodes[c].key == "AXIS")
                .find_map(unit)
        })?;
        let n = &self.nodes[u];
        let factor: f64 = n.words.first()?.parse().ok()?;
        let name = n.texts.first().cloned().unwrap_or_else(|| "unit".into());
        // A metre written as 1.0000000001 is a metre.
        let factor = if (factor - 1.0).abs() < 1e-9 {
            1.0
        } else {
            factor
        };
        (factor > 0.0).then_some((printable(&name), factor))
    }

    /// Its name: the first node's quoted text (`PROJCS["WGS 84 / UTM zone
    /// 33N", …`).
    fn name(&self) -> String {
        self.nodes
            .first()
            .and_then(|n| n.texts.first())
            .map(|t| printable(t.trim()))
            .filter(|t| !t.is_empty())
            .unwrap_or_else(|| "a WKT coordinate system".into())
    }
}

/// A header's text as a message may quote it: control characters (a NUL
/// written inside a name) left out.
fn printable(s: &str) -> String {
    s.chars().filter(|c| !c.is_control()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kind(w: &str) -> &'static str {
        match from_wkt(w) {
            Some(c) if c.degrees => "geographic",
            Some(_) => "projected",
            None => "none",
        }
    }

    /// Whether a WKT's x and y are degrees: its first CRS keyword (the
    /// horizontal one of a compound CRS, the projected one that holds a
    /// geographic base); an Earth-centred or local CRS is neither. Spaces
    /// before brackets and keywords inside names change nothing.
    #[test]
    fn a_wkt_tells_degrees_from_metres() {
        for (wkt, want) in [
            (r#"GEOGCS["WGS 84",DATUM["WGS_1984"]]"#, "geographic"),
            (
                r#"PROJCS["WGS 84 / UTM zone 33N",GEOGCS["WGS 84"]]"#,
                "projected",
            ),
            (
                r#"PROJCS ["WGS 84 / UTM zone 33N", GEOGCS ["WGS 84"]]"#,
                "projected",
            ),
            (r#"PROJCRS["UTM 33N",BASEGEOGCRS["WGS 84"]]"#, "projected"),
            (r#"PROJCRS("UTM 33N",BASEGEOGCRS("WGS 84"))"#, "projected"),
            (r#"GEOGCRS["WGS 84",CS[ellipsoidal,2]]"#, "geographic"),
            (r#"GEODCRS["WGS 84",CS[ellipsoidal,3]]"#, "geographic"),
            (r#"GEODCRS["WGS 84",CS[Cartesian,3]]"#, "none"),
            (r#"GEOCCS["WGS 84 (geocentric)",DATUM["WGS_1984"]]"#, "none"),
            (
                r#"COMPD_CS["WGS 84 + EGM96",GEOGCS["WGS 84"],VERT_CS["EGM96"]]"#,
                "geographic",
            ),
            (
                r#"COMPOUNDCRS["UTM + NAVD88",PROJCRS["UTM"],VERTCRS["NAVD88"]]"#,
                "projected",
            ),
            (
                r#"BOUNDCRS[SOURCECRS[GEOGCRS["NAD27"]],TARGETCRS[GEOGCRS["WGS 84"]]]"#,
                "geographic",
            ),
            (r#"LOCAL_CS["SLAM map",UNIT["metre",1]]"#, "none"),
            (r#"LOCAL_CS["not a GEOGCS[ frame"]"#, "none"),
            ("garbage", "none"),
        ] {
            assert_eq!(kind(wkt), want, "{wkt}");
        }
        let name = |w: &str| Wkt::parse(w).name();
        assert_eq!(
            name("PROJCS[\"WGS 84 / UTM zone 33N\",GEOGCS"),
            "WGS 84 / UTM zone 33N"
        );
        assert_eq!(name("garbage"), "a WKT coordinate system");
    }

    /// A WKT's length units: a State Plane map's foot for x and y, a
    /// compound CRS's heights in feet for z alone; never the degree of a
    /// geographic base (whatever its name), a parameter's unit or a
    /// transformation's scale.
    #[test]
    fn a_wkt_names_its_length_units() {
        let units = |w: &str| {
            let c = from_wkt(w).unwrap();
            let s = |u: Option<(String, f64)>| u.map(|(n, m)| format!("{n} {m}"));
            (s(c.horizontal_unit), s(c.vertical_unit))
        };
        let feet = r#"PROJCS["NAD83 / Oregon",GEOGCS["NAD83",UNIT["degree",0.0174532925199433]],PARAMETER["false_easting",1312335.958005249],UNIT["foot",0.3048,AUTHORITY["EPSG","9002"]]]"#;
        assert_eq!(units(feet), (Some("foot 0.3048".into()), None));
        let us = r#"PROJCRS["NAD83 / Texas",BASEGEOGCRS["NAD83",ANGLEUNIT["degree",0.0174532925199433]],CONVERSION["SPCS",PARAMETER["False easting",1968500,LENGTHUNIT["US survey foot",0.304800609601219]]],CS[Cartesian,2],AXIS["easting (X)",east,LENGTHUNIT["US survey foot",0.304800609601219]]]"#;
        assert_eq!(
            units(us),
            (Some("US survey foot 0.304800609601219".into()), None)
        );
        let ft_heights = r#"COMPD_CS["UTM 10N + NAVD88 height (ftUS)",PROJCS["NAD83 / UTM zone 10N",GEOGCS["NAD83",UNIT["degree",0.0174532925199433]],UNIT["metre",1]],VERT_CS["NAVD88 height (ftUS)",VERT_DATUM["North American Vertical Datum 1988",2005],UNIT["US survey foot",0.304800609601219]]]"#;
        assert_eq!(
            units(ft_heights),
            (None, Some("US survey foot 0.304800609601219".into()))
        );
        let ft_m = r#"COMPD_CS["NAD83 / Texas South Central (ftUS) + NAVD88 height",PROJCS["NAD83 / Texas South Central (ftUS)",GEOGCS["NAD83",UNIT["degree",0.0174532925199433]],UNIT["US survey foot",0.3048006096012192]],VERT_CS["NAVD88 height",VERT_DATUM["North American Vertical Datum 1988",2005],UNIT["metre",1.0]]]"#;
        assert_eq!(
            units(ft_m),
            (
                Some("US survey foot 0.3048006096012192".into()),
                Some("metre 1".into())
            )
        );
        for metres in [
            r#"PROJCS["WGS 84 / UTM zone 33N",GEOGCS["WGS 84",UNIT["degree",0.0174532925199433]],UNIT["metre",1,AUTHORITY["EPSG","9001"]]]"#,
            r#"BOUNDCRS[SOURCECRS[PROJCRS["UTM",LENGTHUNIT["metre",1]]],ABRIDGEDTRANSFORMATION[PARAMETER["Scale difference",1,SCALEUNIT["parts per million",1E-06]]]]"#,
            r#"PROJCS["x",GEOGCS["y",UNIT["degré",0.0174532925199433]],UNIT["metre",1]]"#,
            r#"PROJCS ["x", GEOGCS ["y", UNIT ["grad", 0.015707963267949]], UNIT ["metre", 1]]"#,
        ] {
            assert_eq!(units(metres), (None, None), "{metres}");
        }
        assert_eq!(
            units(r#"PROJCS ["x", UNIT ["foot", 0.3048]]"#).0.as_deref(),
            Some("foot 0.3048")
        );
    }
}
