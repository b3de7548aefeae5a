#!/usr/bin/env bash
# Larger REAL point clouds found while building this corpus but NOT copied (size budget,
# or absent from the mirror snapshot because >= 4 MiB). Default: just print the list.
# With --download DIR it tries raw.githubusercontent.com at the pinned commit using curl;
# this needs internet access (the machine that built the corpus had none, so it was never run there).
set -euo pipefail
# repo | commit | path | licence | note
LIST='
PointCloudLibrary/pcl|1fdb03883eab28f642e938d9bf4d317903212cb4|test/table_scene_mug_stereo_textured.pcd|BSD-3-Clause|1.7 MB stereo/RGB-D tabletop scene, organized cloud with NaNs
PointCloudLibrary/pcl|1fdb03883eab28f642e938d9bf4d317903212cb4|test/office1.pcd|BSD-3-Clause|1.9 MB indoor office RGB-D scan
PointCloudLibrary/pcl|1fdb03883eab28f642e938d9bf4d317903212cb4|test/five_people.pcd|BSD-3-Clause|2.0 MB indoor RGB-D scan with people
PointCloudLibrary/pcl|1fdb03883eab28f642e938d9bf4d317903212cb4|test/milk_cartoon_all_small_clorox.pcd|BSD-3-Clause|2.5 MB RGB-D tabletop scene
PointCloudLibrary/pcl|1fdb03883eab28f642e938d9bf4d317903212cb4|test/grabber_sequences/pcd/frame_20121214T142256.332395.pcd|BSD-3-Clause|1.8 MB OpenNI grabber frame (organized, NaNs)
PointCloudLibrary/pcl|1fdb03883eab28f642e938d9bf4d317903212cb4|doc/tutorials/content/sources/alignment_prerejective/rs1.pcd|BSD-3-Clause|3.5 MB indoor kitchen scene scan
PDAL/PDAL|ccf0ab7046072f68cab78734e90d0d3149f3af10|test/data/las/autzen_trim.las|BSD-3-Clause|3.7 MB Autzen airborne LiDAR (uncompressed twin of autzen_trim.laz)
PDAL/PDAL|ccf0ab7046072f68cab78734e90d0d3149f3af10|test/data/las/autzen_trim_7.las|BSD-3-Clause|4.0 MB Autzen, LAS 1.4 point format 7
PDAL/PDAL|ccf0ab7046072f68cab78734e90d0d3149f3af10|test/data/copc/lone-star.copc.laz|BSD-3-Clause|2.7 MB Lone Star (TX) airborne LiDAR, COPC
PDAL/PDAL|ccf0ab7046072f68cab78734e90d0d3149f3af10|test/data/laz/las_with_several_extra_byte_bloc.laz|BSD-3-Clause|3.2 MB LAZ with extra-byte dims
PDAL/PDAL|ccf0ab7046072f68cab78734e90d0d3149f3af10|test/data/draco/red-rocks.laz|BSD-3-Clause|>=4 MiB (absent from mirror) Red Rocks amphitheatre LiDAR
PDAL/PDAL|ccf0ab7046072f68cab78734e90d0d3149f3af10|test/data/las/4_6.las|BSD-3-Clause|>=4 MiB (absent from mirror) LAS 1.4 pf6 (4_6_crop.las is its 0.8 MB crop)
koide3/fast_gicp|df839a89a3cc04b8e94cbfecf46330a7c01fbea4|data/251371071.pcd|BSD-3-Clause|1.1 MB second Velodyne frame (pair of the copied one)
koide3/small_gicp|aea131352e0d362d3e579a334c477cfafa5ee5eb|data/target.ply|MIT|1.1 MB Velodyne frame as PLY
koide3/hdl_localization|de2dc7769aa2412876d05ae6161408d3295b6a3c|data/map.pcd|BSD-2-Clause|>=4 MiB (absent from mirror) outdoor SLAM global map (hdl_graph_slam output)
davidcaron/pye57|b8d20999f3037c580bf1fe1dcb239c50a8f764ad|tests/test_data/pumpAVisualReferenceImage.e57|MIT|4.1 MB E57 (pump scan + reference image)
davidcaron/pye57|b8d20999f3037c580bf1fe1dcb239c50a8f764ad|tests/test_data/test.e57|MIT|>=4 MiB (absent from mirror) E57 test scan
davidcaron/pye57|b8d20999f3037c580bf1fe1dcb239c50a8f764ad|tests/test_data/testSpherical.e57|MIT|>=4 MiB (absent from mirror) E57 spherical-coordinate scan
asmaloney/libE57Format-test-data|bbcacec05d60f923869545c5eab33d94c390d50e|reference/bunnyDouble.e57|libe57.org Test Data License (MIT-style)|0.7 MB bunny E57 with float64 coords
laspy/laspy|fbc5b375f9dad6bae499a81ca436bee361ecf047|tests/data/file_with_both_wkt_and_geotiff_vlrs.las|BSD-2-Clause|0.8 MB real LAS with WKT+GeoTIFF VLRs
'
if [[ "${1:-}" != "--download" ]]; then
  echo "repo | commit | path | licence | note"
  echo "$LIST" | sed '/^$/d'
  echo; echo "(listing only; run: $0 --download DIR   to try fetching with curl)"
  exit 0
fi
dir=${2:?usage: $0 --download DIR}; mkdir -p "$dir"
echo "$LIST" | sed '/^$/d' | while IFS='|' read -r repo commit path lic note; do
  out="$dir/${repo//\//_}__${path//\//_}"
  url="https://raw.githubusercontent.com/$repo/$commit/$path"
  if curl -fsSL --retry 2 -o "$out" "$url"; then echo "ok   $out"; else echo "FAIL $url"; rm -f "$out"; fi
done
