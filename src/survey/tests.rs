use super::*;
use std::io::Write;

fn file(content: &str) -> tempfile::NamedTempFile {
    let mut f = tempfile::NamedTempFile::new().unwrap();
    f.write_all(content.as_bytes()).unwrap();
    f
}

fn err(content: &str) -> String {
    let f = file(content);
    read_survey(f.path(), &SurveyOptions::default())
        .unwrap_err()
        .to_string()
}

#[test]
fn a_misspelt_column_is_refused_and_extra_columns_are_not() {
    for (head, meant) in [
        ("id,x,y,z,antena_height", "antenna_height"),
        ("id,x,y,z,antenna height", "antenna_height"),
        ("id,x,y,z_m", "z"),
        ("id,lat,lon,alt_m", "alt"),
        ("id,lat,lon,alt (m)", "alt"),
        ("id,lattitude,lon", "latitude"),
        ("id,latitude,longitud", "longitude"),
        ("id,x,y,z,antena", "antenna"),
        ("id,easting,northing,height [m]", "height"),
    ] {
        let cols = head.split(',').count();
        let row = vec!["1"; cols].join(",");
        let e = err(&format!("# comment first\n{head}\n{row}\n"));
        assert!(
            e.contains(":2: column `") && e.contains(&format!("did you mean `{meant}`?")),
            "{head}: {e}"
        );
    }
    assert!(
        err("id,x,y,antenna height\n1,2,3,4\n").contains("must not also give an antenna height")
    );
    // Columns a survey export carries that mapgauge does not read.
    let f = file(
        "id,x,y,z,description,notes,note,code,type,date,time,sigma_x,hrms,status,geoid_height,weight,names,easting_sd,northing rms,along,east2,rol\nT1,1,2,3,a,b,c,d,e,f,g,0.01,0.02,fix,40,1,n,0.1,0.1,a,b,c\n",
    );
    let s = read_survey(f.path(), &SurveyOptions::default()).unwrap();
    assert_eq!(s.targets.len(), 1);
    // Heights under the other kind of survey's names, or under a name
    // read by neither, would be lost: refused, saying where they go.
    for (head, want) in [
        ("id,lat,lon,height", "heights go in `alt`"),
        ("id,lat,lon,z", "heights go in `alt`"),
        ("id,x,y,alt", "heights go in `z`"),
        ("id,x,y,elevation", "heights go in `z`"),
        ("id,lat,lon,elev", "heights go in `alt`"),
    ] {
        let e = err(&format!("{head}\n1,2,3,4\n"));
        assert!(
            e.contains(":1: column `") && e.contains(want),
            "{head}: {e}"
        );
    }
}

#[test]
fn local_survey_with_comments_roles_and_antenna() {
    let f = file(
        "# site A\nid,x,y,z,role,antenna_height\n# base at pillar\nT1,350000.123456,4150000.654321,12.5,control,1.8\nT2,350010,4150005,13,check,\n",
    );
    let s = read_survey(f.path(), &SurveyOptions::default()).unwrap();
    assert_eq!(s.frame, SurveyFrame::Local);
    assert_eq!(s.targets.len(), 2);
    let t1 = &s.targets[0];
    assert_eq!(t1.id, "T1");
    assert_eq!(t1.position.x, 350000.123456);
    assert_eq!(t1.position.y, 4150000.654321);
    assert_eq!(t1.role, Some(Role::Control));
    assert!((t1.reference().z - 10.7).abs() < 1e-12);
    assert_eq!(t1.line, 4);
    assert_eq!(s.targets[1].antenna_height, 0.0);
    assert!(s.has_z());
}

/// 42 where 0.42 m was meant would put that target's height 41.6 m off:
/// refused with its line, as a size out of range is.
#[test]
fn an_antenna_height_in_centimetres_is_refused_with_its_line() {
    let f = file("id,x,y,z,antenna_height\nT1,0,0,1,0.42\nT2,10,0,1,42\n");
    let e = read_survey(f.path(), &SurveyOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(":3") && e.contains("antenna_height 42") && e.contains("centimetres"),
        "{e}"
    );
    // A survey written in millimetres throughout: its positions are named
    // too, so the next run does not stop on them.
    let f = file("id,x,y,z,antenna_height\nT1,0,0,1000,420\n");
    let e = read_survey(f.path(), &SurveyOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("convert its x, y and z too"), "{e}");
    let f = file("id,x,y,z,antenna_height\nT1,0,0,1,-0.3\nT2,10,0,1,2.5\n");
    assert!(read_survey(f.path(), &SurveyOptions::default()).is_ok());
}

/// A survey controller's export (`Point,Easting,Northing,…`) is read; a
/// spreadsheet's decimal comma is named.
#[test]
fn a_controllers_point_column_and_a_decimal_comma() {
    let f = file("Point,Easting,Northing,Z\nT1,0,0,1\nT2,10,0,1\n");
    let s = read_survey(f.path(), &SurveyOptions::default()).unwrap();
    assert_eq!(s.targets[1].id, "T2");
    // A total station's export: the instrument's station is not the id;
    // a `section` column is not a misspelt one.
    let f = file("station,point,x,y\nS1,T1,0,0\nS1,T2,10,0\n");
    let s = read_survey(f.path(), &SurveyOptions::default()).unwrap();
    assert_eq!(s.targets[1].id, "T2");
    let f = file("id,section,x,y\nT1,a,0,0\nT2,b,10,0\n");
    assert!(read_survey(f.path(), &SurveyOptions::default()).is_ok());
    let f = file("id;x;y\nT1;0;0\nT2;-0,2125;1\n");
    let e = read_survey(f.path(), &SurveyOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("a decimal comma?") && e.contains("`-0.2125`"),
        "{e}"
    );
}

/// Latitude and longitude exchanged at 127° E: the range error says so.
#[test]
fn a_latitude_past_90_names_the_likely_swap() {
    let f = file("id,lat,lon,alt\na,127.36,36.37,50\n");
    let e = read_survey(f.path(), &SurveyOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("latitude 127.36 is outside -90..90")
            && e.contains("lat and lon columns swapped"),
        "{e}"
    );
    let f = file("id,lat,lon,alt\na,127.36,136.37,50\n");
    let e = read_survey(f.path(), &SurveyOptions::default())
        .unwrap_err()
        .to_string();
    assert!(!e.contains("swapped"), "{e}");
}

#[test]
fn geodetic_survey_about_first_target_and_given_origin() {
    let f = file("id,lat,lon,alt\na,36.0,127.0,50\nb,36.001,127.0,51\n");
    let s = read_survey(f.path(), &SurveyOptions::default()).unwrap();
    assert_eq!(s.frame, SurveyFrame::Wgs84Enu);
    assert!(s.targets[0].position.coords.norm() < 1e-9);
    let b = s.targets[1].position;
    assert!(
        (b.y - 110.95).abs() < 0.1 && b.x.abs() < 1e-6 && (b.z - 1.0).abs() < 0.01,
        "{b}"
    );
    let o = Geodetic {
        lat: 36.0,
        lon: 127.0,
        alt: 0.0,
    };
    let s2 = read_survey(f.path(), &SurveyOptions { origin: Some(o) }).unwrap();
    assert!((s2.targets[0].position.z - 50.0).abs() < 1e-6);
    assert_eq!(s2.origin, Some(o));
}

#[test]
fn bad_surveys_name_file_and_line() {
    let e = err("id,x,y\n1,0,0\n\n# c\n\n1,1,1\n");
    assert!(e.contains(":6:") && e.contains("duplicate"), "{e}");
    let e = err("id,x\n1,0\n");
    assert!(
        e.contains(":1:") && e.contains("missing position columns"),
        "{e}"
    );
    let e = err("x,y\n1,0\n");
    assert!(e.contains("missing column `id`"), "{e}");
    let e = err("id,x,y\n1,0,0\n2,abc,0\n");
    assert!(
        e.contains(":3:") && e.contains("`abc` is not a finite number"),
        "{e}"
    );
    let e = err("id,x,y\n1,0,0\n2,5\n");
    assert!(
        e.contains(":3:") && e.contains("missing value in column `y`"),
        "{e}"
    );
    let e = err("id,lat,lon\n1,91,0\n");
    assert!(e.contains(":2:") && e.contains("latitude"), "{e}");
    // CRLF files (Windows survey software) name the same lines: csv's own
    // count named the line above.
    let e = err("id,x,y\r\n1,0,0\r\n2,abc,0\r\n");
    assert!(e.contains(":3:"), "{e}");
    let e = err("# c\r\n\r\nid,x,y\r\n1,0,0\r\n\r\n1,1,1\r\n");
    assert!(e.contains(":6:") && e.contains("duplicate"), "{e}");
    // An old Mac's lone CR ends lines too.
    let e = err("id,x,y\r1,0,0\r2,abc,0\r");
    assert!(e.contains(":3:"), "{e}");
    // Bytes that are not UTF-8: the line, without csv's own count.
    let mut f = tempfile::NamedTempFile::new().unwrap();
    f.write_all(b"# c\r\nid,x,y\r\n1,0,0\r\n2,\xff1,0\r\n")
        .unwrap();
    let e = read_survey(f.path(), &SurveyOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(":4: not valid CSV: not UTF-8 text") && !e.contains("line:"),
        "{e}"
    );
    let e = err("id,x,y,role\n1,0,0,boss\n");
    assert!(e.contains(":2:") && e.contains("role"), "{e}");
    let e = err("# only a comment\n");
    assert!(e.contains("no header"), "{e}");
    let e = err("id,x,y\n");
    assert!(e.contains("no targets"), "{e}");
    let e = err("id,x,y,lat,lon\n1,0,0,0,0\n");
    assert!(e.contains("both"), "{e}");
    let e = err("id,x,y\n1,NaN,0\n");
    assert!(e.contains("not a finite number"), "{e}");
}

#[test]
fn estimates_reader() {
    let f = file("id,x,y,z,score\n1,1.5,2.5,3.5,0.9\n2,,,,\n");
    let e = read_estimates(f.path()).unwrap();
    assert_eq!(
        e[0].status,
        EstimateStatus::Found(Point::new(1.5, 2.5, 3.5))
    );
    assert!(e[0].has_z);
    assert!(matches!(e[1].status, EstimateStatus::NotFound { .. }));
    let f = file("id,x,y\n1,1,2\n1,1,2\n");
    let m = read_estimates(f.path()).unwrap_err().to_string();
    assert!(m.contains(":3:") && m.contains("duplicate"), "{m}");
    let f = file("id,x,y\n1,1,\n");
    let m = read_estimates(f.path()).unwrap_err().to_string();
    assert!(m.contains(":2:") && m.contains("`y`"), "{m}");
}

/// eval's targets.csv: the map columns are the estimates; excluded rows
/// keep their position (errors judges them again), not-found rows none.
#[test]
fn estimates_from_evals_targets_csv() {
    let f = file(
        "id,status,reason,survey_x,survey_y,survey_z,map_x,map_y,map_z,aligned_x\n\
         1,ok,,10,20,1,1.5,2.5,3.5,10\n\
         2,not_found,no target here,11,21,1,,,,\n\
         3,excluded,gross error,12,22,1,4,5,,12\n\
         4,not_found,wrong object,13,23,1,7,8,9,\n\
         5,ambiguous,mapped twice,14,24,1,,,,\n",
    );
    let e = read_estimates(f.path()).unwrap();
    assert_eq!(
        e[0].status,
        EstimateStatus::Found(Point::new(1.5, 2.5, 3.5))
    );
    assert!(e[0].has_z);
    assert!(
        matches!(&e[1].status, EstimateStatus::NotFound { reason } if reason == "no target here")
    );
    assert_eq!(
        e[2].status,
        EstimateStatus::Found(Point::new(4.0, 5.0, 0.0))
    );
    assert!(!e[2].has_z);
    assert!(
        matches!(&e[3].status, EstimateStatus::NotFound { reason } if reason == "wrong object")
    );
    assert!(
        matches!(&e[4].status, EstimateStatus::Ambiguous { reason } if reason == "mapped twice")
    );
}
