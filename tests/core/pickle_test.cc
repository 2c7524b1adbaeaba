// The restricted pickle reader against pickles written by the project's Python (pickle +
// numpy, protocols 2-5, numpy 1.x module names) and hostile ones: disallowed globals, REDUCE
// gadgets, deep nesting, cycles, huge lengths, output bombs and every truncation.
#include "mlspaces/core/pickle.h"

#include <cstdio>
#include <map>
#include <string>

#include "test_util.h"

namespace mlspaces {
namespace {

using ::mlspaces::testing::Slurp;
using ::mlspaces::testing::TempDir;
using ::testing::HasSubstr;
using namespace std::string_literals;

std::string Hex(const void* data, size_t n) {
  static const char* kDigits = "0123456789abcdef";
  std::string out;
  for (size_t i = 0; i < n; ++i) {
    const auto b = static_cast<const uint8_t*>(data)[i];
    out += kDigits[b >> 4];
    out += kDigits[b & 15];
  }
  return out;
}

/// The same canonical line as describe() in testdata/make_pickles.py.
std::string Describe(const PickleValue& v) {
  using Kind = PickleValue::Kind;
  switch (v.kind) {
    case Kind::kNone:
      return "None";
    case Kind::kBool:
      return v.boolean ? "True" : "False";
    case Kind::kInt:
      return std::to_string(v.integer);
    case Kind::kFloat: {
      uint8_t be[8];
      uint64_t u;
      std::memcpy(&u, &v.real, 8);
      for (int i = 0; i < 8; ++i) be[i] = static_cast<uint8_t>(u >> (56 - 8 * i));
      return "f:" + Hex(be, 8);
    }
    case Kind::kStr:
      return "s:" + Hex(v.text.data(), v.text.size());
    case Kind::kBytes:
      return "b:" + Hex(v.text.data(), v.text.size());
    case Kind::kByteArray:
      return "ba:" + Hex(v.text.data(), v.text.size());
    case Kind::kList:
    case Kind::kTuple: {
      std::string out = v.kind == Kind::kList ? "[" : "(";
      for (size_t i = 0; i < v.items.size(); ++i) out += (i ? "," : "") + Describe(v.items[i]);
      return out + (v.kind == Kind::kList ? "]" : ")");
    }
    case Kind::kDict: {
      std::string out = "{";
      for (size_t i = 0; i < v.entries.size(); ++i) {
        out += (i ? "," : "") + Describe(v.entries[i].key) + ":" + Describe(v.entries[i].value);
      }
      return out + "}";
    }
    case Kind::kArray: {
      std::string shape;
      for (size_t i = 0; i < v.array.shape.size(); ++i) {
        shape += (i ? "," : "") + std::to_string(v.array.shape[i]);
      }
      return std::string(v.numpy_scalar ? "np(" : "nd(") + DTypeDescr(v.array.dtype).substr(1) +
             ";" + shape + ";" + (v.fortran_order ? "1" : "0") + ";" +
             Hex(v.array.data.data(), v.array.data.size()) + ")";
    }
  }
  return "?";
}

PickleValue Parse(const std::string& bytes, const PickleLimits& limits = {}) {
  return ParsePickle({reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()}, "test.pkl",
                     "key", limits);
}

/// The error message ParsePickle gives for `bytes` ("" when it decodes).
std::string ErrorOf(const std::string& bytes, const PickleLimits& limits = {}) {
  try {
    Parse(bytes, limits);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

class PythonPickles : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new TempDir();
    ASSERT_EQ(0, testing::RunPython(dir_->path(),
                                    Slurp(std::string(MLSPACES_TESTDATA_DIR) + "/make_pickles.py"),
                                    testing::ShellQuote((dir_->path() / "out").string())));
    for (const auto& e : std::filesystem::directory_iterator(dir_->path() / "out")) {
      if (e.path().extension() != ".pkl") continue;
      (*cases_)[e.path().stem().string()] = {
          Slurp(e.path()), Slurp(std::filesystem::path(e.path()).replace_extension(".expect"))};
    }
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  static TempDir* dir_;
  static std::map<std::string, std::pair<std::string, std::string>>* cases_;
};
TempDir* PythonPickles::dir_ = nullptr;
std::map<std::string, std::pair<std::string, std::string>>* PythonPickles::cases_ =
    new std::map<std::string, std::pair<std::string, std::string>>();

TEST_F(PythonPickles, EveryValueKindAndProtocolDecodesAsPythonSees) {
  size_t decoded = 0, refused = 0;
  for (const auto& [name, c] : *cases_) {
    const auto& [bytes, expect] = c;
    if (expect.rfind("ERROR: ", 0) == 0) {
      const std::string error = ErrorOf(bytes);
      EXPECT_THAT(error, HasSubstr(expect.substr(7))) << name;
      EXPECT_THAT(error, HasSubstr("test.pkl: key: pickle: ")) << name;
      EXPECT_THAT(error, HasSubstr(" at byte ")) << name;
      ++refused;
    } else {
      try {
        EXPECT_EQ(Describe(Parse(bytes)), expect) << name;
      } catch (const Error& e) {
        ADD_FAILURE() << name << ": " << e.what();
      }
      ++decoded;
    }
  }
  // Every case of values() in 4 protocols (27 of them), plus numpy-1.x rewrites.
  EXPECT_GE(decoded, 27u * 4 + 20);
  EXPECT_GE(refused, 20u);
  for (const char* want : {"f16_p5", "fortran_p4", "fortran_p5", "zero_d_p2", "scalars_p3",
                           "annotation_p4", "f16_p2_numpy1", "scalars_p2_numpy1"}) {
    EXPECT_EQ(cases_->count(want), 1u) << want;
  }
}

TEST_F(PythonPickles, AnnotationKeepsKeyOrderAndArrays) {
  const PickleValue v = Parse(cases_->at("annotation_p4").first);
  ASSERT_EQ(v.kind, PickleValue::Kind::kDict);
  ASSERT_EQ(v.entries.size(), 8u);
  EXPECT_EQ(v.entries[0].key.text, "uid");
  EXPECT_EQ(v.entries[7].key.text, "clip_text_features");
  const PickleValue* img = v.Find("clip_img_features");
  ASSERT_NE(img, nullptr);
  EXPECT_EQ(img->array.dtype, DType::kF2);
  EXPECT_EQ(img->array.shape, (std::vector<size_t>{3, 768}));
  EXPECT_EQ(v.Find("nope"), nullptr);
}

TEST_F(PythonPickles, FortranArraysComeOutInCOrder) {
  const PickleValue v = Parse(cases_->at("fortran_p5").first);
  ASSERT_EQ(v.kind, PickleValue::Kind::kArray);
  EXPECT_TRUE(v.fortran_order);
  const std::vector<double> d = v.array.ToDoubles();  // arange(24).reshape(2,3,4)
  for (size_t i = 0; i < d.size(); ++i) EXPECT_EQ(d[i], static_cast<double>(i));
}

TEST_F(PythonPickles, EveryTruncationIsAnError) {
  size_t tried = 0;
  for (const char* name :
       {"annotation_p2", "annotation_p4", "annotation_p5", "nested_p2", "dict_keys_p4",
        "scalars_p5", "ints_p3", "unicode_p4", "fortran_f16_p2_numpy1", "shared_p5", "bytes_p5"}) {
    const std::string& bytes = cases_->at(name).first;
    const size_t step = bytes.size() > 4000 ? 97 : 1;  // the 70 KB bytes case: sampled
    for (size_t n = 0; n < bytes.size(); n += step) {
      EXPECT_NE(ErrorOf(bytes.substr(0, n)), "") << name << " cut at " << n;
      ++tried;
    }
  }
  EXPECT_GT(tried, 2000u);
}

std::string P2(const std::string& body) { return "\x80\x02"s + body + "."; }

TEST(PickleHostile, GlobalsOutsideTheAllowList) {
  EXPECT_THAT(ErrorOf(P2("cos\nsystem\n(S'ls'\ntR")),
              HasSubstr("global os.system is not allowed at byte 2"));
  EXPECT_THAT(ErrorOf(P2("cbuiltins\neval\n")), HasSubstr("global builtins.eval is not allowed"));
  // A prefix of an allowed name, and an allowed module with another name.
  EXPECT_THAT(ErrorOf(P2("cnumpy\nload\n")), HasSubstr("global numpy.load is not allowed"));
  EXPECT_THAT(ErrorOf(P2("cnumpy.core.multiarray\n_reconstruc\n")), HasSubstr("not allowed"));
  // STACK_GLOBAL with non-strings.
  EXPECT_THAT(ErrorOf("\x80\x04K\x01K\x02\x93."s), HasSubstr("STACK_GLOBAL of non-strings"));
}

TEST(PickleHostile, ReduceAndBuildGadgets) {
  // Calling an allowed class that is not a reconstructor.
  EXPECT_THAT(ErrorOf(P2("cnumpy\nndarray\n)R")), HasSubstr("REDUCE of a non-allowed callable"));
  // Calling a value.
  EXPECT_THAT(ErrorOf(P2("N)R")), HasSubstr("REDUCE of a non-allowed callable"));
  // _codecs.encode with another codec.
  EXPECT_THAT(ErrorOf(P2("c_codecs\nencode\nX\x01\x00\x00\x00"
                         "aX\x06\x00\x00\x00"
                         "base64\x86R"s)),
              HasSubstr("_codecs.encode takes (str, 'latin1') only"));
  // BUILD on a dict (setstate on an ordinary object).
  EXPECT_THAT(ErrorOf(P2("}N\x85"
                         "b")),
              HasSubstr("BUILD on anything but a numpy array or dtype"));
  // Object construction, persistent ids, extensions, out-of-band buffers.
  EXPECT_THAT(ErrorOf(P2("cnumpy\ndtype\n)\x81")), HasSubstr("NEWOBJ"));
  EXPECT_THAT(ErrorOf(P2("(i__main__\nX\n")), HasSubstr("object construction"));
  EXPECT_THAT(ErrorOf(P2("N\x51")), HasSubstr("persistent ids are not allowed"));
  EXPECT_THAT(ErrorOf(P2("\x82\x01")), HasSubstr("extension codes are not allowed"));
  EXPECT_THAT(ErrorOf(std::string("\x80\x05\x97.", 4)), HasSubstr("out-of-band buffers"));
  // Text-protocol opcodes are outside protocols 2-5's writers.
  EXPECT_THAT(ErrorOf(P2("I1\n")), HasSubstr("unsupported opcode"));
}

TEST(PickleHostile, DeepNestingCyclesAndBombs) {
  // 100k nested lists (EMPTY_LIST x n, APPEND x n-1).
  std::string deep(100000, ']');
  deep += std::string(99999, 'a');
  EXPECT_THAT(ErrorOf(P2(deep)), HasSubstr("nested deeper than 200"));
  // 100k nested tuples (TUPLE1 x n) and marks.
  EXPECT_THAT(ErrorOf(P2("N" + std::string(100000, '\x85'))), HasSubstr("nested deeper"));
  EXPECT_THAT(ErrorOf(P2(std::string(100000, '('))), HasSubstr("marks nested deeper than 200"));
  // A list that contains itself.
  EXPECT_THAT(ErrorOf(P2("]q\x00h\x00"
                         "a"s)),
              HasSubstr("nested deeper"));
  // A tuple key nested past the limit.
  EXPECT_THAT(ErrorOf(P2("}N" + std::string(300, '\x85') + "Ns")), HasSubstr("dict key nested"));
  // Doubling through the memo: 2^40 copies of 1 KB.
  std::string bomb = "B\x00\x04\x00\x00"s + std::string(1024, 'x') + "q\x00"s;
  for (int i = 0; i < 40; ++i) bomb += "0h\x00h\x00\x86q\x00"s;
  bomb = P2(bomb);
  PickleLimits small;
  small.max_output_bytes = 1 << 20;
  EXPECT_THAT(ErrorOf(bomb, small), HasSubstr("decoded value larger than 1048576 bytes"));
  EXPECT_THAT(ErrorOf(bomb), HasSubstr("decoded value larger than"));
  // Memo limit.
  PickleLimits memo;
  memo.max_memo = 3;
  EXPECT_THAT(ErrorOf(P2("N\x94\x94\x94\x94"), memo), HasSubstr("memo holds more than 3"));
  EXPECT_THAT(ErrorOf(P2("h\x07")), HasSubstr("memo entry 7 was never stored"));
  EXPECT_THAT(ErrorOf(P2("N\x94h\x00h\x00\x86"s)), HasSubstr("STOP with a stack"));
}

TEST(PickleHostile, HugeDeclaredLengths) {
  EXPECT_THAT(ErrorOf(P2("\x8d\xff\xff\xff\xff\xff\xff\xff\x7f"s)),
              HasSubstr("declared length 9223372036854775807 exceeds"));
  EXPECT_THAT(ErrorOf(P2("X\xff\xff\xff\xff")), HasSubstr("declared length"));
  EXPECT_THAT(ErrorOf(P2(std::string("\x8b\xff\xff\xff\x7f", 5))), HasSubstr("declared length"));
  EXPECT_THAT(ErrorOf(P2(std::string("\x95\xff\xff\xff\xff\xff\xff\xff\xff", 9))),
              HasSubstr("declared length"));
  // A shape that claims more elements than the data holds (and one that overflows).
  const std::string frombuffer =
      "cnumpy.core.numeric\n_frombuffer\n(C\x04\x00\x00\x00\x00"
      "cnumpy\ndtype\nX\x02\x00\x00\x00"
      "f4\x89\x88\x87R"s;
  EXPECT_THAT(
      ErrorOf(P2(frombuffer + "\x8a\x08\xff\xff\xff\xff\xff\xff\xff\x3f\x8a\x08\xff\xff\xff\xff\xff"
                              "\xff\xff\x3f\x86X\x01\x00\x00\x00"
                              "CtR"s)),
      HasSubstr("array too large"));
  EXPECT_THAT(ErrorOf(P2(frombuffer + "K\x02\x85X\x01\x00\x00\x00"
                                      "CtR"s)),
              HasSubstr("array data holds 4 bytes, shape (2,) of <f4 needs 8"));
}

TEST(PickleHostile, StreamShape) {
  EXPECT_THAT(ErrorOf(""), HasSubstr("not a protocol 2-5 pickle"));
  EXPECT_THAT(ErrorOf(std::string("\x80\x06N.", 4)), HasSubstr("unsupported pickle protocol 6"));
  EXPECT_THAT(ErrorOf(P2("NN")), HasSubstr("STOP with a stack of other than one value"));
  EXPECT_THAT(ErrorOf(P2("N") + "junk"), HasSubstr("4 bytes after STOP"));
  EXPECT_THAT(ErrorOf(P2("0")), HasSubstr("stack underflow"));
  EXPECT_THAT(ErrorOf(P2("(0")), HasSubstr("stack underflow"));  // not below the mark
  EXPECT_THAT(ErrorOf(P2("]N]s")), HasSubstr("SETITEM on a non-dict"));
  EXPECT_THAT(ErrorOf(P2("}]Ns")), HasSubstr("unhashable dict key"));
  EXPECT_THAT(ErrorOf(P2("X\x02\x00\x00\x00\xc3\x28"s)), HasSubstr("not valid UTF-8"));
  EXPECT_THAT(ErrorOf(P2("cnumpy\ndtype\n")), HasSubstr("holds a numpy type or callable"));
  // Float keys: integral ones equal ints, huge ones stay floats (found by the fuzzer).
  EXPECT_EQ(Describe(Parse(P2("}(G\x3f\xf0\x00\x00\x00\x00\x00\x00NK\x01Nu"s))),
            "{f:3ff0000000000000:None}");
  EXPECT_EQ(Describe(Parse(P2("}(G\x7e\x70\x00\x00\x00\x00\x00\x00NK\x01Nu"s))),
            "{f:7e70000000000000:None,1:None}");
  // Python's dict semantics: a repeated key keeps its first place and takes the last value.
  EXPECT_EQ(Describe(Parse(P2("}(K\x01K\x02K\x03K\x04K\x01K\x05u"))), "{1:5,3:4}");
  EXPECT_EQ(Describe(Parse(P2("\x8a\x09\x00\x00\x00\x00\x00\x00\x00\x80\xff"s))),
            "-9223372036854775808");
  EXPECT_THAT(ErrorOf(P2("\x8a\x09\x00\x00\x00\x00\x00\x00\x00\x80\x00"s)),
              HasSubstr("integer larger than 64 bits"));
}

}  // namespace
}  // namespace mlspaces
