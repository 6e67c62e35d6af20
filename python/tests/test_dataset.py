"""The data set readers on the repository's example data set and on a
written session's files."""

import os

import pandas as pd

import skinread

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")


def test_the_example_data_set_reads_as_one_frame():
    df = skinread.read_dataset(os.path.join(ROOT, "data", "example"))
    traces = skinread.read_traces(os.path.join(ROOT, "data", "example"))
    assert len(traces) == 6
    assert len(df) == sum(len(t) for t in traces.values())
    assert set(df["file"]) == set(traces)
    assert df["cs_pf"].gt(0).all()


def test_flags_are_decoded_by_name_and_do_not_shadow_pandas(tmp_path):
    p = tmp_path / "records.csv"
    p.write_text(
        "segment,seq,t_us,sensor,f1_hz,z1_re_ohm,z1_im_ohm,f2_hz,z2_re_ohm,z2_im_ohm,c_pf,r_ohm,stretch_mm,chosen_hz,chi2,sigma_ln_c,flags\n"
        "1,1,500,0,1000,1,-1,4000,1,-1,205.0,7e5,0,4000,1,0.001,0\n"
        "1,2,500,1,1000,1,-1,4000,1,-1,,,,4000,1,,384\n"
        "1,3,1500,0,1000,1,-1,4000,1,-1,205.0,7e5,0,4000,1,0.001,4608\n"
    )
    df = skinread.read_records(str(tmp_path))
    assert "flags" not in df.columns and isinstance(df.flags, pd.Flags)
    assert list(df["flag_bits"]) == [0, 384, 4608]
    assert list(df["valid"]) == [True, False, True]
    assert list(df["MODEL"]) == [False, True, False]
    assert list(df["UNCERTAIN"]) == [False, True, False]
    assert list(df["TONE_LEFT_OUT"]) == [False, False, True]
    assert skinread.names(4608) == ["UNCALIBRATED", "TONE_LEFT_OUT"]
    per = skinread.by_sensor(df)
    assert sorted(per) == [0, 1] and list(per[0]["t_us"]) == [500, 1500]


def test_records_get_both_clocks_and_markers_read_back(tmp_path):
    # A device 100 ppm slow that started at 2026-12-03 10:00:00 UTC.
    (tmp_path / "session.json").write_text(
        '{"segments": [{"clock": {"offset_unix_s": 1796292000.0, "rate": 1.0001}}, {"clock": null}],'
        ' "skin": {"name": "hand", "board": "", "sensors": [{"name": "palm", "board": "", "index": 0,'
        ' "group": null, "place": [3.0, 4.0], "outline": []}]}}'
    )
    (tmp_path / "records.csv").write_text(
        "segment,seq,t_us,sensor,f1_hz,z1_re_ohm,z1_im_ohm,f2_hz,z2_re_ohm,z2_im_ohm,c_pf,r_ohm,stretch_mm,chosen_hz,chi2,sigma_ln_c,flags,host_utc_us\n"
        "1,1,1000000,0,1000,1,-1,4000,1,-1,205.0,7e5,0,4000,1,0.001,0,1796292001003000\n"
        "2,1,500,0,1000,1,-1,4000,1,-1,205.0,7e5,0,4000,1,0.001,0,\n"
    )
    df = skinread.read_records(str(tmp_path))
    assert df["arrived_utc"].iat[0] == pd.Timestamp("2026-12-03T10:00:01.003Z")
    assert pd.isna(df["arrived_utc"].iat[1])
    # 1 s of the device is 1.0001 s of the host's.
    assert df["t_utc"].iat[0] == pd.Timestamp("2026-12-03T10:00:01.0001Z")
    assert pd.isna(df["t_utc"].iat[1])
    # The skin's names by sensor.
    assert list(df["name"]) == ["palm", "palm"]
    assert skinread.skin(str(tmp_path)).loc[0, ["name", "x", "y"]].tolist() == ["palm", 3.0, 4.0]
    (tmp_path / "markers.csv").write_text(
        "host_utc_us,segment,device_t_us,source,text\n"
        '1796292002000000,1,999900,stdin,"grasp, ""firm"""\n'
        "1796292003000000,2,,dashboard,let go\n"
    )
    m = skinread.read_markers(str(tmp_path))
    assert list(m["text"]) == ['grasp, "firm"', "let go"]
    assert m["host_utc"].iat[1] == pd.Timestamp("2026-12-03T10:00:03Z")
    assert m["device_t_us"].iat[0] == 999900 and pd.isna(m["device_t_us"].iat[1])
