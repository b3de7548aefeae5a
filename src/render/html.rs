//! The HTML shell every page mapgauge writes shares: the stylesheet and a
//! standalone page around a body (`mapgauge table --format html`, the
//! report, the failure page). No script and no external resource.

use super::escape;
use std::fmt::Write as _;

/// The stylesheet shared by every page mapgauge writes.
pub const CSS: &str = "
:root{--ink:#222;--muted:#666;--line:#ddd;--bg:#f6f7f9;--card:#fff;--accent:#1f77b4;--bad:#8e44ad}
*{box-sizing:border-box}
body{margin:0;background:var(--bg);color:var(--ink);font:15px/1.45 'DejaVu Sans',Verdana,Arial,sans-serif}
main{max-width:1000px;margin:0 auto;padding:24px 20px 48px}
h1{font-size:26px;margin:0 0 4px}
h2{font-size:19px;margin:32px 0 10px;padding-bottom:4px;border-bottom:2px solid var(--line)}
h3{font-size:16px;margin:0 0 6px}
p.sub{color:var(--muted);margin:0 0 8px;overflow-wrap:anywhere}
.cards{display:flex;flex-wrap:wrap;gap:10px}
.card{background:var(--card);border:1px solid var(--line);border-radius:8px;padding:10px 14px;min-width:150px;flex:1}
.card .k{color:var(--muted);font-size:12px;text-transform:uppercase;letter-spacing:.04em}
.card .v{font-size:22px;font-weight:bold}
.card .s{color:var(--muted);font-size:12px}
figure{margin:10px 0;background:var(--card);border:1px solid var(--line);border-radius:8px;padding:8px;overflow-x:auto}
figure svg{display:block;max-width:100%;height:auto}
figcaption{color:var(--muted);font-size:13px;margin-top:4px}
.target{background:var(--card);border:1px solid var(--line);border-radius:8px;padding:12px 14px;margin:14px 0}
.target figure{border:none;padding:0;margin:6px 0 0}
.target.failed{border-left:5px solid var(--bad)}
.badge{display:inline-block;border-radius:10px;padding:1px 9px;font-size:12px;font-weight:bold;color:#fff;background:#27ae60;vertical-align:middle}
.failed .badge{background:var(--bad)}
.facts{color:var(--muted);font-size:13px;margin:2px 0}
.reason{color:var(--bad);font-weight:bold}
table.grid{border-collapse:collapse;margin:8px 0 16px;background:var(--card);font-size:13px}
table.grid th,table.grid td{border-bottom:1px solid var(--line);padding:4px 10px;text-align:right;white-space:nowrap}
table.grid th:first-child,table.grid td:first-child,table.grid td.t,table.grid th.t{text-align:left}
table.grid td.t,table.grid td.w{white-space:normal;min-width:8em}
table.grid thead th{border-bottom:2px solid #999}
.scroll{overflow-x:auto}
ul.warn{color:#a04000}
code,pre{font-family:'DejaVu Sans Mono',Menlo,Consolas,monospace;font-size:12px}
pre{background:var(--card);border:1px solid var(--line);padding:10px;overflow-x:auto}
table.grid td.hash{font-family:'DejaVu Sans Mono',Menlo,Consolas,monospace;font-size:11px;text-align:left;white-space:normal;word-break:break-all;min-width:24em}
table.grid td.path{text-align:left;white-space:normal;word-break:break-all}
footer{color:var(--muted);font-size:12px;margin-top:36px}
@media print{body{background:#fff}.target,figure,.card{break-inside:avoid}}
";

/// A complete page around `body` (already HTML).
pub fn page(title: &str, body: &str, meta: &[(&str, String)]) -> String {
    let mut o = String::with_capacity(body.len() + CSS.len() + 512);
    o.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    o.push_str("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n");
    let _ = writeln!(
        o,
        "<meta name=\"generator\" content=\"mapgauge {}\">",
        env!("CARGO_PKG_VERSION")
    );
    for (k, v) in meta {
        let _ = writeln!(o, "<meta name=\"{}\" content=\"{}\">", escape(k), escape(v));
    }
    let _ = writeln!(o, "<title>{}</title>", escape(title));
    let _ = writeln!(o, "<style>{CSS}</style>\n</head>\n<body>\n<main>");
    o.push_str(body);
    o.push_str("\n</main>\n</body>\n</html>\n");
    o
}
