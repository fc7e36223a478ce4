"""Expand the shorthand commonsense table below into priors.json (the file the package reads).

    python tools/make_priors.py [OUT]     (default: sdovon_mj/data/semantics/priors.json of this checkout)

A maintainer script, not package data: run it from any folder of the checkout.

Edit the tables here, re-run, commit both files (a test checks they agree). Shorthand: region
letters K kitchen, L living room, B bedroom, T bathroom, O office, D dining room, H hallway,
U laundry room, C closet, each followed by a 0-10 score; receptacles as name+score with spaces
written as underscores. Missing entries mean 0. Curated by the sdovon-mj authors (see "source").
"""
import json
import pathlib
import re
import sys

R = {"K": "kitchen", "L": "living room", "B": "bedroom", "T": "bathroom", "O": "office", "D": "dining room",
     "H": "hallway", "U": "laundry room", "C": "closet"}
REC = ["table", "dining table", "coffee table", "side table", "desk", "dresser", "nightstand", "bookshelf", "shelf",
       "bed", "sofa", "couch", "armchair", "chair", "counter", "cabinet", "tv stand", "sink", "bench", "stool"]
def regs(s):
    out = {}
    for tok in s.split():
        m = re.fullmatch(r"([A-Z])(\d+)", tok); assert m, tok
        out[R[m.group(1)]] = int(m.group(2))
    return dict(sorted(out.items()))
def recs(s):
    out = {}
    for tok in s.split():
        m = re.fullmatch(r"([a-z_]+)(\d+)", tok); assert m, tok
        name = m.group(1).replace("_", " "); assert name in REC, name
        out[name] = int(m.group(2))
    if "sofa" in out and "couch" not in out: out["couch"] = out["sofa"]
    if "table" in out:
        out.setdefault("dining table", out["table"])
    return dict(sorted(out.items()))

# furniture / receptacles / fixtures: label -> (kind, regions)
FURN = {
 "bed": ("receptacle", "B10 C1"), "nightstand": ("receptacle", "B10 L1"), "dresser": ("receptacle", "B9 C4 D4 L4 H3"),
 "wardrobe": ("furniture", "B9 C7 H3"), "headboard": ("furniture", "B10"), "crib": ("furniture", "B10"),
 "vanity": ("furniture", "T8 B6"),
 "toilet": ("fixture", "T10"), "bathtub": ("fixture", "T10"), "shower": ("fixture", "T10"),
 "sink": ("receptacle", "T8 K7 U3"), "bathroom cabinet": ("furniture", "T10"), "towel rack": ("fixture", "T10"),
 "mirror": ("furniture", "T7 B6 H5 C3 L2"), "bath mat": ("furniture", "T10"),
 "fridge": ("fixture", "K10"), "stove": ("fixture", "K10"), "oven": ("fixture", "K10"), "microwave": ("fixture", "K10 O1"),
 "dishwasher": ("fixture", "K10"), "counter": ("receptacle", "K10 T6 U3"), "kitchen cabinet": ("furniture", "K10"),
 "kitchen island": ("receptacle", "K10 D2"), "range hood": ("fixture", "K10"), "toaster": ("fixture", "K10"),
 "desk": ("receptacle", "O10 B5 L2"), "office chair": ("furniture", "O10 B3"), "monitor": ("object", "O10 B3 L2"),
 "filing cabinet": ("furniture", "O10"), "printer": ("fixture", "O10 L1"), "computer": ("object", "O10 B3 L2"),
 "dining table": ("receptacle", "D10 K6 L3"), "dining chair": ("furniture", "D10 K5 L2"),
 "chair": ("receptacle", "D7 O6 K4 L4 B3"), "table": ("receptacle", "D9 K7 L6 O4 B2"), "stool": ("receptacle", "K7 T3 D3 L2 O2 B2"),
 "sideboard": ("furniture", "D9 L5 K3 H3"), "china cabinet": ("furniture", "D9 K4 L2"),
 "sofa": ("receptacle", "L10 O2 B2"), "couch": ("receptacle", "L10 O2 B2"), "armchair": ("receptacle", "L9 B4 O3"),
 "coffee table": ("receptacle", "L10 O1 B1"), "tv": ("fixture", "L10 B5 K1 O1"), "tv stand": ("receptacle", "L10 B4"),
 "side table": ("receptacle", "L8 B6 H3 O2"), "fireplace": ("fixture", "L10 D2 B1"), "ottoman": ("receptacle", "L9 B4"),
 "rug": ("furniture", "L7 B6 D4 O3 H3 T2 K1"), "carpet": ("furniture", "L7 B6 D3 O3 H3"),
 "piano": ("furniture", "L9 D1"), "bookshelf": ("receptacle", "L7 O9 B5 H2"), "shelf": ("receptacle", "L6 O6 K6 B5 T5 U5 C5 H3 D3"),
 "cabinet": ("receptacle", "K8 T6 D5 L5 O5 U5 B4 H3 C3"), "floor lamp": ("furniture", "L9 B6 O5"),
 "curtain": ("furniture", "L7 B8 D4 O4 K2 T3"), "plant": ("object", "L8 D5 O5 H5 B4 K4 T2"),
 "washing machine": ("fixture", "U10 T5 K3"), "dryer": ("fixture", "U10 T3"), "laundry basket": ("object", "U10 B6 T6 C5"),
 "ironing board": ("furniture", "U10 C4 B2"), "shoe rack": ("furniture", "H10 C6 B3 U2"), "coat rack": ("furniture", "H10 C4 L2"),
 "bench": ("receptacle", "H9 D5 L3 B3 U2"), "umbrella stand": ("furniture", "H10"), "console table": ("receptacle", "H9 L6 D2"),
 "radiator": ("fixture", "L4 B4 T4 O4 H4 K3 D3"), "door": ("structure", ""), "window": ("structure", ""), "wall": ("structure", ""),
 "floor": ("structure", ""), "ceiling": ("structure", ""), "stairs": ("structure", "H6 L2"), "light": ("structure", ""),
 "ceiling light": ("structure", ""), "picture": ("furniture", "L7 B5 D5 H5 O4 T1"), "clothes": ("object", "B9 C9 U8 T3"),
 "speaker": ("object", "L9 O5 B4"), "wine rack": ("furniture", "D8 K8 L3"), "trash can": ("object", "K9 T7 O6 B3 L3 U4"),
 # fixtures of every room (the default world's houses carry them, as scans label them): no evidence of a region
 "light switch": ("structure", ""), "outlet": ("structure", ""), "vent": ("structure", ""), "smoke detector": ("structure", ""),
}
# manipulable objects: label -> (regions, receptacles)
OBJ = {
 "mug": ("K10 O6 D6 L4 B2", "counter10 table7 dining_table8 desk7 coffee_table6 cabinet6 shelf5 side_table4 nightstand3"),
 "cup": ("K10 D7 L5 O5 B3", "counter9 dining_table9 table8 desk6 coffee_table6 cabinet7 shelf5 side_table4 nightstand4"),
 "bowl": ("K10 D8 L3", "counter9 dining_table9 table8 cabinet7 shelf5 coffee_table4"),
 "plate": ("K10 D9 L2", "dining_table10 table8 counter9 cabinet7 shelf4 coffee_table3"),
 "book": ("L8 O9 B8", "bookshelf10 shelf8 desk8 nightstand8 coffee_table7 table5 side_table6 sofa5 bed5 dresser3 armchair3"),
 "magazine": ("L9 O5 B6 T3", "coffee_table10 side_table7 sofa6 table5 desk5 nightstand5 bookshelf6 shelf5 bed3"),
 "newspaper": ("L9 K5 D5 O4", "coffee_table10 table7 dining_table7 sofa6 side_table6 desk5 armchair4"),
 "bottle": ("K10 D6 L3 O3 T3", "counter9 table7 dining_table7 cabinet6 shelf6 desk4 coffee_table4"),
 "water bottle": ("K8 O7 B5 L5 D4", "desk8 counter8 table7 nightstand6 coffee_table5 shelf5 dining_table5"),
 "wine bottle": ("K9 D9 L5", "dining_table9 counter9 table8 cabinet7 shelf6 coffee_table4"),
 "can": ("K10 L3 D3 O2", "counter9 cabinet8 shelf7 table6 dining_table4 coffee_table3 desk3"),
 "cereal box": ("K10 D5", "counter10 cabinet9 shelf7 table6 dining_table6"),
 "cracker box": ("K10 D4 L2", "counter10 cabinet9 shelf7 table6 dining_table5 coffee_table3"),
 "laptop": ("O10 B6 L6 D2", "desk10 table6 coffee_table6 bed6 sofa5 dining_table3 nightstand3 armchair3"),
 "remote": ("L10 B5", "coffee_table10 sofa9 tv_stand9 side_table7 nightstand5 bed4 armchair6 table4"),
 "remote control": ("L10 B5", "coffee_table10 sofa9 tv_stand9 side_table7 nightstand5 bed4 armchair6 table4"),
 "pillow": ("B10 L8", "bed10 sofa9 armchair7 bench3 chair2"),
 "cushion": ("L10 B7", "sofa10 armchair9 bed7 chair5 bench5"),
 "blanket": ("B10 L7 C3", "bed10 sofa8 armchair6 dresser3 bench3"),
 "stuffed toy": ("B10 L6", "bed10 sofa6 nightstand5 shelf6 armchair5 dresser4 bookshelf4 chair3"),
 "teddy bear": ("B10 L6", "bed10 sofa6 nightstand5 shelf6 armchair5 dresser4 bookshelf4 chair3"),
 "toy": ("B9 L8", "bed6 shelf7 coffee_table5 sofa4 table4 bookshelf5"),
 "vase": ("L10 D8 B5 H5 O3", "coffee_table8 dining_table9 table8 side_table8 shelf7 bookshelf5 dresser6 cabinet5 tv_stand5"),
 "potted plant": ("L10 D6 O6 H5 B5 K4 T3", "side_table8 shelf7 coffee_table6 table6 desk5 dining_table5 tv_stand5 dresser4 bookshelf4 counter4"),
 "lamp": ("B9 L9 O8 H3", "nightstand10 side_table9 desk9 dresser7 table5 bookshelf4 shelf3 coffee_table3"),
 "table lamp": ("B9 L9 O8", "nightstand10 side_table9 desk9 dresser7 table5 bookshelf3 shelf3"),
 "shoe": ("H10 C8 B6", "bench8 shelf7 cabinet4 bed1 chair2"),
 "toothbrush": ("T10", "sink10 counter8 shelf6 cabinet5"),
 "toothpaste": ("T10", "sink10 counter8 shelf6 cabinet6"),
 "soap dispenser": ("T10 K7 U2", "sink10 counter9 shelf5 cabinet3"),
 "soap": ("T10 K4 U3", "sink10 counter7 shelf5 cabinet4"),
 "soap bottle": ("T10 K6 U3", "sink10 counter9 shelf6 cabinet4"),
 "shampoo": ("T10", "shelf8 sink6 counter6 cabinet6"),
 "towel": ("T10 K5 U5 B3", "shelf8 counter7 cabinet7 sink5 bed3 dresser3 bench2 chair2"),
 "hand towel": ("T10 K7", "counter8 sink7 shelf7 cabinet5"),
 "toilet paper": ("T10 U2 C2", "shelf9 cabinet8 counter6 sink4"),
 "tissue box": ("B8 L8 T7 O6", "nightstand10 side_table8 coffee_table8 desk7 counter6 dresser6 shelf5 table5"),
 "hair dryer": ("T10 B6", "counter8 sink6 dresser7 shelf6 cabinet6 nightstand3"),
 "spoon": ("K10 D8", "counter9 dining_table9 table8 cabinet7 sink5 shelf3"),
 "fork": ("K10 D9", "dining_table10 counter9 table8 cabinet7 sink5 shelf3"),
 "knife": ("K10 D7", "counter10 dining_table7 table6 cabinet7 sink4"),
 "spatula": ("K10", "counter10 cabinet7 sink5 table3 shelf4"),
 "ladle": ("K10", "counter10 cabinet7 sink4 shelf4 table3"),
 "pan": ("K10", "counter10 cabinet8 sink6 shelf5 table3"),
 "frying pan": ("K10", "counter10 cabinet8 sink6 shelf5 table3"),
 "pot": ("K10", "counter10 cabinet8 sink5 shelf5 table4"),
 "kettle": ("K10 O2", "counter10 table5 shelf5 cabinet4 dining_table4"),
 "teapot": ("K10 D7 L5", "counter9 dining_table8 table8 coffee_table7 shelf6 cabinet6 side_table4"),
 "pitcher": ("K10 D7", "counter9 dining_table8 table8 shelf5 cabinet6"),
 "cutting board": ("K10", "counter10 cabinet6 shelf5 table5 sink3"),
 "sponge": ("K10 T6 U4", "sink10 counter9 shelf4 cabinet4"),
 "dish sponge": ("K10", "sink10 counter9 cabinet4 shelf3"),
 "salt shaker": ("K10 D8", "counter9 dining_table9 table8 cabinet6 shelf6"),
 "pepper shaker": ("K10 D8", "counter9 dining_table9 table8 cabinet6 shelf6"),
 "toaster": ("K10", "counter10 cabinet3 shelf3 table3"),
 "coffee maker": ("K10 O3", "counter10 cabinet4 shelf3 table3"),
 "wine glass": ("D9 K9 L6", "dining_table10 table8 counter8 cabinet8 coffee_table6 shelf6 side_table4"),
 "glass": ("K10 D8 L4", "counter9 dining_table9 table8 cabinet8 coffee_table5 shelf6 nightstand3 desk3"),
 "apple": ("K10 D7 L3", "counter9 dining_table8 table8 coffee_table4 shelf3 desk3"),
 "banana": ("K10 D7 L3", "counter10 dining_table8 table8 coffee_table4 desk3"),
 "orange": ("K10 D7 L3", "counter9 dining_table8 table8 coffee_table4 desk3"),
 "lemon": ("K10 D5", "counter10 dining_table6 table6 shelf3"),
 "pear": ("K10 D7", "counter9 dining_table8 table8 coffee_table3"),
 "bread": ("K10 D7", "counter10 dining_table7 table7 cabinet5 shelf4"),
 "egg": ("K10", "counter10 table5 dining_table4 cabinet3 shelf3"),
 "tomato": ("K10", "counter10 table6 dining_table5"),
 "potato": ("K10", "counter10 cabinet6 table5 shelf4"),
 "lettuce": ("K10", "counter10 table5 dining_table4"),
 "fruit bowl": ("K10 D9 L5", "dining_table10 counter9 table9 coffee_table6 side_table3"),
 "keyboard": ("O10 B4 L3", "desk10 table6 shelf3 coffee_table2"),
 "mouse": ("O10 B4 L2", "desk10 table6 shelf2"),
 "computer mouse": ("O10 B4 L2", "desk10 table6 shelf2"),
 "monitor": ("O10 B3 L2", "desk10 table6 tv_stand4 shelf3 dresser2"),
 "phone": ("L8 B8 O8 K5", "nightstand9 desk9 coffee_table8 table7 side_table7 sofa6 bed6 counter6 dresser5 armchair4"),
 "cell phone": ("L8 B8 O8 K5", "nightstand9 desk9 coffee_table8 table7 side_table7 sofa6 bed6 counter6 dresser5 armchair4"),
 "alarm clock": ("B10 O3 L2", "nightstand10 dresser7 side_table6 desk6 shelf6 bookshelf4 table3"),
 "clock": ("L7 B7 K6 O6 D5", "shelf8 side_table7 nightstand7 desk6 dresser6 bookshelf6 tv_stand5 table4 counter4"),
 "watch": ("B10 T4 O4", "nightstand10 dresser9 desk6 side_table5 shelf4 counter3 table3"),
 "candle": ("L9 D8 B7 T6", "dining_table8 coffee_table9 side_table8 table7 shelf7 dresser6 nightstand6 bookshelf4 counter4 tv_stand4"),
 "picture frame": ("L9 B8 O7 H5", "shelf9 dresser8 nightstand8 side_table8 desk7 bookshelf8 tv_stand6 table5 cabinet5"),
 "statue": ("L10 O6 H5 B4", "shelf9 bookshelf8 side_table7 coffee_table6 tv_stand6 dresser5 desk5 cabinet5 table4"),
 "pen": ("O10 B4 L3", "desk10 table5 nightstand4 shelf4 coffee_table4 bookshelf3"),
 "pencil": ("O10 B4", "desk10 table5 shelf4 nightstand3"),
 "marker": ("O10 L3", "desk10 table6 shelf5 coffee_table3"),
 "scissors": ("O9 K7 U4", "desk10 counter7 table6 shelf6 cabinet6"),
 "stapler": ("O10", "desk10 table5 shelf5 cabinet4"),
 "notebook": ("O10 B6 L4", "desk10 table6 nightstand6 bookshelf6 shelf6 coffee_table5 bed4"),
 "paper": ("O10 L3", "desk10 table6 shelf5 coffee_table4 cabinet4"),
 "tablet": ("L8 B8 O8", "desk9 coffee_table8 nightstand8 sofa7 bed7 table6 side_table6 armchair4"),
 "headphones": ("O9 B8 L6", "desk10 nightstand7 bed6 shelf6 coffee_table5 sofa5 table5 dresser4"),
 "camera": ("O7 L7 B6", "desk8 shelf8 table6 dresser5 coffee_table5 bookshelf5 nightstand4"),
 "game controller": ("L10 B7", "coffee_table10 tv_stand9 sofa8 bed6 nightstand4 side_table6 desk4"),
 "board game": ("L9 B5 D5", "shelf9 bookshelf7 coffee_table8 table7 dining_table6 cabinet6"),
 "basketball": ("B7 H6 L4", "shelf5 bed4 bench4 chair2"),
 "ball": ("L7 B7 H5", "shelf5 bed4 sofa3 bench3"),
 "tennis racket": ("B6 H7 C7", "shelf6 bed4 bench5"),
 "dumbbell": ("B8 L6 O4", "shelf6 table5 desk5 bench7 bed2 sofa3"),
 "key": ("H10 L6 K5 B4", "side_table8 table7 counter7 dresser6 shelf6 bench5 nightstand5 desk5"),
 "wallet": ("B8 H8 L6", "nightstand9 dresser9 side_table7 desk6 table6 counter5 shelf5"),
 "credit card": ("O6 B6 L6 H4", "desk8 nightstand7 dresser7 table6 coffee_table5 counter5"),
 "sunglasses": ("B7 H8 L5", "dresser8 nightstand7 side_table7 shelf6 desk5 table5 counter5"),
 "glasses": ("B9 O7 L7", "nightstand10 desk8 dresser7 side_table7 coffee_table6 table5 bookshelf3"),
 "hat": ("H9 B8 C8", "shelf7 dresser7 bench6 bed5 chair4 cabinet4"),
 "bag": ("H8 B8 C6 L5 O5", "chair7 bench7 bed6 sofa5 desk5 table5 shelf5"),
 "backpack": ("B8 H8 O7 L4", "chair8 bench7 bed6 desk6 sofa4"),
 "handbag": ("B8 H8 C7 L5", "dresser7 bench7 bed6 chair7 table5 sofa5 shelf6"),
 "box": ("C8 O6 L5 B5 H4 U4", "shelf8 cabinet6 table6 desk5 bookshelf5 dresser4"),
 "basket": ("U8 L6 B6 K6 T6 C6", "shelf8 counter6 table5 cabinet5 dresser4 bench5"),
 "spray bottle": ("U9 T9 K8", "shelf8 counter8 cabinet8 sink6"),
 "cleaning spray": ("U9 T8 K8", "shelf8 counter8 cabinet8 sink6"),
 "detergent": ("U10 K6 T4", "shelf9 cabinet8 counter7 sink4"),
 "bleach cleanser": ("U10 T7 K6", "shelf9 cabinet8 counter6 sink5"),
 "cosmetics": ("T9 B9", "dresser10 counter8 shelf7 sink6 nightstand5 cabinet5"),
 "perfume": ("B9 T9", "dresser10 counter8 shelf7 nightstand6 sink4 cabinet5"),
 "lotion": ("T10 B7", "counter9 shelf8 sink7 dresser7 nightstand6 cabinet6"),
 "razor": ("T10", "sink9 counter9 shelf7 cabinet7"),
 "comb": ("T9 B8", "counter8 dresser9 sink7 shelf6 nightstand5"),
 "hairbrush": ("T9 B8", "counter8 dresser9 sink7 shelf6 nightstand5"),
 "plunger": ("T10 U4", "sink2 shelf3 cabinet3"),
 "tray": ("K9 D7 L7", "counter8 dining_table7 table7 coffee_table7 shelf6 cabinet6"),
 "jar": ("K10 D4 L3", "counter10 shelf8 cabinet8 table5 dining_table5"),
 "food can": ("K10", "counter9 cabinet9 shelf8 table5"),
 "soup can": ("K10", "counter9 cabinet9 shelf8 table5"),
 "mustard bottle": ("K10 D6", "counter9 cabinet8 dining_table7 table7 shelf7"),
 "ketchup": ("K10 D7", "counter9 dining_table8 table7 cabinet7 shelf6"),
 "sugar box": ("K10", "counter10 cabinet9 shelf8 table5"),
 "snack": ("K9 L7 O4 B3", "counter8 coffee_table8 table6 cabinet7 shelf6 desk4 sofa3"),
 "chips": ("K9 L8", "counter8 coffee_table8 cabinet7 table6 shelf6 sofa4"),
 "cookie jar": ("K10", "counter10 shelf7 cabinet6 table5"),
 "coffee cup": ("K9 O8 L6 D6 B3", "counter9 desk8 table8 dining_table8 coffee_table8 side_table5 nightstand4 shelf3"),
 "thermos": ("K9 O6", "counter9 desk6 table6 cabinet6 shelf6"),
 "lunch box": ("K10 O5", "counter10 table7 cabinet6 desk5 shelf5"),
 "houseplant": ("L10 D6 O6 H5 B5 K4 T3", "side_table8 shelf7 coffee_table6 table6 desk5 dining_table5 tv_stand5 dresser4 bookshelf4 counter4"),
 "flower": ("L9 D8 B5 K5", "dining_table9 table8 coffee_table8 side_table7 counter6 shelf6 dresser5"),
 "succulent": ("L8 O8 K6 B6 T5", "desk8 shelf8 side_table7 coffee_table7 counter6 table6 nightstand5"),
 "globe": ("O10 L5 B5", "desk10 bookshelf8 shelf8 table5 side_table5"),
 "trophy": ("L8 O8 B7", "shelf10 bookshelf9 tv_stand6 dresser6 cabinet6 desk5"),
 "puzzle": ("L9 B5", "coffee_table8 table8 dining_table6 shelf7 bookshelf5"),
 "rubik's cube": ("B8 O7 L7", "desk8 shelf7 nightstand6 coffee_table6 table5 bookshelf5 bed3"),
 "lego": ("B9 L8", "table6 shelf7 coffee_table7 desk6 bed3"),
 "toy car": ("B9 L8", "shelf7 bed4 coffee_table6 table5 nightstand3"),
 "doll": ("B10 L6", "bed9 shelf8 nightstand5 dresser5 sofa5 bookshelf5"),
 "power drill": ("U6 H5 K3 O3 C5", "shelf8 cabinet7 table5 counter4 bench5"),
 "hammer": ("U6 C5 K4 H4", "shelf7 cabinet8 table5 counter4 bench6"),
 "screwdriver": ("U6 K5 O4 C4", "cabinet8 shelf7 desk5 table5 counter5"),
 "flashlight": ("H7 B7 K6 U6 C6", "nightstand8 shelf8 cabinet8 counter5 dresser5 desk4"),
 "umbrella": ("H10 C6", "bench6 shelf5 chair3"),
 "candle holder": ("D8 L9 B6", "dining_table9 coffee_table8 side_table7 shelf7 table7 dresser5"),
 "bowl of fruit": ("K10 D9 L5", "dining_table10 counter9 table9 coffee_table6"),
 "wine": ("D9 K9 L6", "dining_table9 counter9 table8 cabinet7 coffee_table5 shelf6"),
 "beer": ("K9 L7 D6", "counter8 coffee_table8 table7 dining_table7 cabinet5"),
 "soda can": ("K9 L7 O5 D5", "counter8 coffee_table8 table7 desk6 dining_table6 side_table5"),
 "plush toy": ("B10 L6", "bed10 sofa6 nightstand5 shelf6 armchair5 dresser4 bookshelf4 chair3"),
 "jewelry box": ("B10 T3", "dresser10 nightstand8 shelf6 cabinet4"),
 "laundry detergent": ("U10 T5 K4", "shelf9 cabinet8 counter6"),
 "medicine": ("T10 K6 B5", "cabinet9 shelf8 counter7 nightstand6 sink4"),
 "pill bottle": ("T10 K6 B6", "cabinet9 shelf8 counter7 nightstand7 sink5"),
 "clothes": ("B9 C9 U8 T3", "bed8 dresser7 chair7 armchair5 sofa4 bench5 shelf5 cabinet4"),
 "computer": ("O10 B3 L2", "desk10 table6 shelf2"),
 "laundry basket": ("U10 B6 T6 C5", "bench4 shelf4 bed3 counter3"),
 "plant": ("L8 D5 O5 H5 B4 K4 T2", "side_table8 shelf7 coffee_table6 table6 desk5 dining_table5 tv_stand5 dresser4 bookshelf4 counter4"),
 "speaker": ("L9 O5 B4", "tv_stand10 shelf8 bookshelf7 desk7 side_table6 dresser5 cabinet5 table4"),
 "trash can": ("K9 T7 O6 B3 L3 U4", "counter2 cabinet2"),
}
SYN = {
 "refrigerator": "fridge", "freezer": "fridge", "fridge freezer": "fridge", "cooker": "stove", "range": "stove", "cooktop": "stove",
 "stovetop": "stove", "kitchen counter": "counter", "countertop": "counter", "worktop": "counter", "bathroom counter": "counter",
 "bathroom sink": "sink", "kitchen sink": "sink", "washbasin": "sink", "basin": "sink", "tub": "bathtub", "bath": "bathtub",
 "shower stall": "shower", "bidet": "toilet", "book shelf": "bookshelf", "bookcase": "bookshelf", "book case": "bookshelf",
 "shelves": "shelf", "shelving": "shelf", "wall shelf": "shelf", "night stand": "nightstand", "bedside table": "nightstand",
 "nightstand table": "nightstand", "end table": "side_table", "chest of drawers": "dresser", "drawer": "dresser", "drawers": "dresser",
 "closet": "wardrobe", "armoire": "wardrobe", "television": "tv", "tv set": "tv", "tv cabinet": "tv_stand", "tv console": "tv_stand",
 "media console": "tv_stand", "entertainment center": "tv_stand", "loveseat": "sofa", "love seat": "sofa", "sectional": "sofa",
 "settee": "sofa", "recliner": "armchair", "lounge chair": "armchair", "accent chair": "armchair", "desk chair": "office chair",
 "swivel chair": "office chair", "computer desk": "desk", "writing desk": "desk", "work desk": "desk", "kitchen table": "dining_table",
 "dinner table": "dining_table", "round table": "table", "footstool": "ottoman", "pouf": "ottoman", "bar stool": "stool",
 "nightlight": "lamp", "desk lamp": "lamp", "bedside lamp": "lamp", "standing lamp": "floor lamp", "potted plant": "potted plant",
 "plant pot": "potted plant", "flower pot": "potted plant", "flowerpot": "potted plant", "indoor plant": "potted plant",
 "cellphone": "cell phone", "mobile phone": "cell phone", "smartphone": "cell phone", "telephone": "phone", "tv remote": "remote",
 "stuffed animal": "stuffed toy", "plushie": "plush toy", "soft toy": "stuffed toy", "coffee mug": "mug", "teacup": "cup",
 "tea cup": "cup", "drinking glass": "glass", "tumbler": "glass", "dinner plate": "plate", "dish": "plate", "butter knife": "knife",
 "kitchen knife": "knife", "skillet": "frying pan", "saucepan": "pot", "cooking pot": "pot", "chopping board": "cutting board",
 "bath towel": "towel", "washcloth": "hand towel", "toilet roll": "toilet paper", "tissues": "tissue box", "tissue": "tissue box",
 "laptop computer": "laptop", "notebook computer": "laptop", "computer monitor": "monitor", "screen": "monitor", "display": "monitor",
 "desktop computer": "computer", "pc": "computer", "computer keyboard": "keyboard", "garbage can": "trash can", "trash bin": "trash can",
 "waste bin": "trash can", "wastebasket": "trash can", "dustbin": "trash can", "bin": "trash can", "painting": "picture",
 "poster": "picture", "photo": "picture frame", "photo frame": "picture frame", "sculpture": "statue", "figurine": "statue",
 "spectacles": "glasses", "eyeglasses": "glasses", "purse": "handbag", "keys": "key", "key chain": "key", "keychain": "key",
 "cloth": "towel", "dish towel": "hand towel", "paper towel": "hand towel", "sneaker": "shoe", "shoes": "shoe", "boot": "shoe",
 "slipper": "shoe", "soap bar": "soap", "liquid soap": "soap dispenser", "hand soap": "soap dispenser", "cleanser": "bleach cleanser",
 "cereal": "cereal box", "tomato soup can": "soup can", "tuna can": "food can", "potted meat can": "food can", "pudding box": "sugar box",
 "gelatin box": "sugar box", "coffee machine": "coffee maker", "espresso machine": "coffee maker", "electric kettle": "kettle",
 "tea kettle": "kettle", "water jug": "pitcher", "jug": "pitcher", "salt": "salt shaker", "pepper": "pepper shaker",
 "remote controller": "remote control", "video game controller": "game controller", "gamepad": "game controller",
 "clothing": "clothes", "shirt": "clothes", "jacket": "clothes", "coat": "clothes", "sweater": "clothes", "laundry": "clothes",
 "hamper": "laundry basket", "washer": "washing machine", "clothes dryer": "dryer", "tumble dryer": "dryer", "radiator heater": "radiator",
 "heater": "radiator", "fireplace mantel": "fireplace", "mantel": "fireplace", "area rug": "rug", "doormat": "rug", "mat": "rug",
 "drape": "curtain", "drapes": "curtain", "blinds": "curtain", "duvet": "blanket", "comforter": "blanket", "quilt": "blanket",
 "throw pillow": "cushion", "sofa cushion": "cushion", "bed pillow": "pillow", "flowers": "flower", "bouquet": "flower",
 "backpack bag": "backpack", "school bag": "backpack", "suitcase": "bag", "luggage": "bag", "tote bag": "bag", "storage box": "box",
 "cardboard box": "box", "shoe box": "box", "bucket": "basket", "drill": "power drill", "torch": "flashlight",
 "headphone": "headphones", "earphones": "headphones", "ipad": "tablet", "e reader": "tablet", "magazines": "magazine",
 "books": "book", "novel": "book", "notepad": "notebook", "paper towel roll": "hand towel", "soda": "soda can", "beer can": "beer",
 "beer bottle": "beer", "milk": "bottle", "milk carton": "bottle", "juice": "bottle", "ketchup bottle": "ketchup",
 "hair brush": "hairbrush", "shaver": "razor", "make up": "cosmetics", "makeup": "cosmetics", "lipstick": "cosmetics",
 "dining chair": "dining chair", "kitchen chair": "dining chair", "armchair sofa": "armchair", "couch table": "coffee_table",
 "cocktail table": "coffee_table", "hall table": "console table", "entry table": "console table", "console": "console table",
 "hallway bench": "bench", "shoe cabinet": "shoe rack", "coat hanger": "coat rack", "coat stand": "coat rack", "hat stand": "coat rack",
 "cupboard": "cabinet", "storage cabinet": "cabinet", "buffet": "sideboard", "credenza": "sideboard", "hutch": "china cabinet",
 "island": "kitchen island", "bed frame": "bed", "double bed": "bed", "single bed": "bed", "bunk bed": "bed", "cot": "crib",
 "vanity table": "vanity", "dressing table": "vanity", "toilet seat": "toilet", "bathroom mirror": "mirror", "mirror cabinet": "bathroom cabinet",
 "medicine cabinet": "bathroom cabinet", "towel bar": "towel rack", "towel rail": "towel rack", "dish rack": "counter",
 "microwave oven": "microwave", "range hood fan": "range hood", "extractor hood": "range hood", "tv monitor": "tv",
 "speakers": "speaker", "sound bar": "speaker", "soundbar": "speaker", "bookshelves": "bookshelf", "grand piano": "piano",
 "keyboard piano": "piano", "office desk": "desk", "filing cabinets": "filing cabinet", "file cabinet": "filing cabinet",
 "staircase": "stairs", "stair": "stairs", "doorway": "door", "door frame": "door", "lamp shade": "lamp", "chandelier": "ceiling light",
 "pendant light": "ceiling light", "light fixture": "ceiling light", "ceiling lamp": "ceiling light", "wall lamp": "lamp",
 "floorlamp": "floor lamp", "plant": "plant",
}
REGSYN = {
 "living room": ["lounge", "family room", "sitting room", "den", "tv room", "living area", "living space", "great room",
                 "drawing room", "parlor", "parlour", "recreation room", "rec room", "game room", "media room"],
 "kitchen": ["kitchenette", "pantry", "cooking area", "galley", "kitchen area"],
 "bedroom": ["master bedroom", "guest bedroom", "guest room", "kids room", "children's room", "nursery", "dormitory",
             "sleeping area", "bed room", "master suite", "spare room", "child's room", "teen room"],
 "bathroom": ["restroom", "washroom", "toilet", "wc", "water closet", "lavatory", "powder room", "shower room",
              "bath room", "ensuite", "en suite", "half bath", "master bathroom"],
 "office": ["home office", "study", "study room", "workspace", "work room", "workroom", "library", "computer room",
            "office space", "study area"],
 "dining room": ["dining area", "dining", "breakfast nook", "eating area", "dinette", "dining hall"],
 "hallway": ["hall", "corridor", "entryway", "entrance", "foyer", "entry", "entrance hall", "vestibule", "passage",
             "lobby", "mudroom", "landing", "stairway", "stairwell"],
 "laundry room": ["laundry", "utility room", "utility", "laundry area", "washing room"],
 "closet": ["walk in closet", "wardrobe room", "dressing room", "storage room", "storage", "cloakroom", "store room", "storeroom"],
}
labels = {}
for k, (kind, r) in FURN.items():
    labels[k] = {"kind": kind, "regions": regs(r)}
for k, (r, c) in OBJ.items():
    if k in labels:
        labels[k]["regions"] = regs(r); labels[k]["receptacles"] = recs(c); continue
    labels[k] = {"kind": "object", "regions": regs(r), "receptacles": recs(c)}
syn = {}
for k, v in SYN.items():
    v = v.replace("_", " ")
    if k == v: continue
    assert v in labels, (k, v)
    syn[k] = v
out = {
 "version": "1",
 "source": ("Curated by the sdovon-mj authors: hand-written commonsense scores (0 = never, 10 = typical) of where "
            "household objects and furniture are found (regions) and what they are put on (receptacles). "
            "Written to be consistent with the object-placement conventions of AI2-THOR/ProcTHOR (which objects "
            "may sit on which receptacle types, which rooms hold which objects) and the receptacle annotations of "
            "HSSD/Habitat rearrange scenes, but not copied or derived numerically from any of them; no LLM output "
            "was used. Missing entries mean 0."),
 "regions": list(R.values()),
 "receptacles": REC,
 "region_synonyms": {s: k for k, ss in REGSYN.items() for s in ss},
 "synonyms": dict(sorted(syn.items())),
 "labels": dict(sorted(labels.items())),
}
for k in out["region_synonyms"]: assert k not in R.values()
DEFAULT_OUT = pathlib.Path(__file__).resolve().parent.parent / "sdovon_mj" / "data" / "semantics" / "priors.json"
p = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT_OUT
p.parent.mkdir(parents=True, exist_ok=True)
# one label per line: readable diffs
lines = ["{"]
items = [(k, out[k]) for k in ("version", "source", "regions", "receptacles", "region_synonyms", "synonyms")]
for k, v in items:
    lines.append(f' {json.dumps(k)}: {json.dumps(v, ensure_ascii=False)},')
lines.append(' "labels": {')
L = list(out["labels"].items())
for i, (k, v) in enumerate(L):
    lines.append(f'  {json.dumps(k)}: {json.dumps(v, ensure_ascii=False)}' + ("," if i < len(L) - 1 else ""))
lines.append(" }\n}")
p.write_text("\n".join(lines) + "\n")
json.loads(p.read_text())
print(len(labels), "labels", len(syn), "synonyms")
