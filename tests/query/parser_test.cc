// Parser: every question form, synonyms, plurals, ids and unknown words.
#include "query/parser.h"

#include <gtest/gtest.h>

#include "query/query_options.h"
#include "query/vocabulary.h"

namespace loci::query {
namespace {

class ParserTest : public ::testing::Test {
 protected:
  ParserTest() : vocab_(QueryOptions::Defaults()) {}
  ParsedQuery Parse(const std::string& text) {
    auto q = ParseQuestion(text, vocab_);
    EXPECT_TRUE(q.ok()) << text << ": " << q.status().message();
    return q.ok() ? *q : ParsedQuery{};
  }
  Vocabulary vocab_;
};

using Classes = std::vector<std::string>;

TEST_F(ParserTest, WhereIsTheBook) {
  const ParsedQuery q = Parse("Where is the book?");
  EXPECT_EQ(q.intent, Intent::kWhere);
  ASSERT_TRUE(q.target);
  EXPECT_EQ(q.target->classes, Classes{"book"});
  EXPECT_FALSE(q.target->plural);
  EXPECT_FALSE(q.relation);
  EXPECT_EQ(IntentName(q), "where");
}

TEST_F(ParserTest, WhereIsTheBookOnTheTable) {
  const ParsedQuery q = Parse("where's the book on the table");
  EXPECT_EQ(q.intent, Intent::kWhere);
  EXPECT_EQ(q.target->classes, Classes{"book"});
  ASSERT_TRUE(q.relation);
  EXPECT_EQ(q.relation->kind, RelationKind::kOn);
  EXPECT_EQ(q.relation->anchor->classes, Classes{"dining table"});
}

TEST_F(ParserTest, WhatIsOnTheDesk) {
  const ParsedQuery q = Parse("What is on the desk?");
  EXPECT_EQ(q.intent, Intent::kWhatRelation);
  EXPECT_FALSE(q.target);
  EXPECT_EQ(q.relation->kind, RelationKind::kOn);
  EXPECT_EQ(q.relation->anchor->classes, Classes{"dining table"});
  EXPECT_EQ(IntentName(q), "what_on");
}

TEST_F(ParserTest, IsThereACupNearTheKeyboard) {
  const ParsedQuery q = Parse("is there a cup near the keyboard");
  EXPECT_EQ(q.intent, Intent::kExists);
  EXPECT_EQ(q.target->classes, Classes{"cup"});
  EXPECT_EQ(q.relation->kind, RelationKind::kNear);
  EXPECT_EQ(q.relation->anchor->classes, Classes{"keyboard"});
}

TEST_F(ParserTest, HowManyChairs) {
  const ParsedQuery q = Parse("How many chairs are there?");
  EXPECT_EQ(q.intent, Intent::kCount);
  EXPECT_EQ(q.target->classes, Classes{"chair"});
  EXPECT_TRUE(q.target->plural);
  EXPECT_FALSE(q.relation);
  const ParsedQuery in_map = Parse("how many chairs are in the map");
  EXPECT_EQ(in_map.intent, Intent::kCount);
  EXPECT_FALSE(in_map.relation);
  const ParsedQuery under = Parse("how many chairs are under the tables");
  EXPECT_EQ(under.relation->kind, RelationKind::kUnder);
  EXPECT_TRUE(under.relation->anchor->plural);
}

TEST_F(ParserTest, ListAllObjects) {
  for (const char* text : {"list all objects", "List all the objects.", "what objects are there",
                           "what do you see", "show everything"}) {
    const ParsedQuery q = Parse(text);
    EXPECT_EQ(q.intent, Intent::kList) << text;
    EXPECT_TRUE(!q.target || q.target->any()) << text;
  }
  const ParsedQuery books = Parse("list the books");
  EXPECT_EQ(books.intent, Intent::kList);
  EXPECT_EQ(books.target->classes, Classes{"book"});
}

TEST_F(ParserTest, WhichRobotSawTheLaptopLast) {
  const ParsedQuery q = Parse("Which robot saw the laptop last?");
  EXPECT_EQ(q.intent, Intent::kWhichRobot);
  EXPECT_EQ(q.target->classes, Classes{"laptop"});
  EXPECT_FALSE(q.first_seen);
  EXPECT_TRUE(Parse("who saw the laptop first").first_seen);
}

TEST_F(ParserTest, WhatIsLeftOfTheMonitor) {
  struct Case {
    const char* text;
    RelationKind kind;
  };
  for (const Case& c : {Case{"what is left of the monitor", RelationKind::kLeftOf},
                        Case{"what is to the left of the screen", RelationKind::kLeftOf},
                        Case{"what's on the left side of the display", RelationKind::kLeftOf},
                        Case{"what is right of the tv", RelationKind::kRightOf},
                        Case{"what is in front of the monitor", RelationKind::kInFrontOf},
                        Case{"what is behind the television", RelationKind::kBehind}}) {
    const ParsedQuery q = Parse(c.text);
    EXPECT_EQ(q.intent, Intent::kWhatRelation) << c.text;
    ASSERT_TRUE(q.relation) << c.text;
    EXPECT_EQ(q.relation->kind, c.kind) << c.text;
    EXPECT_EQ(q.relation->anchor->classes, Classes{"tv"}) << c.text;
  }
}

TEST_F(ParserTest, OtherRelations) {
  struct Case {
    const char* text;
    RelationKind kind;
  };
  for (const Case& c : {Case{"what is under the table", RelationKind::kUnder},
                        Case{"what is beneath the table", RelationKind::kUnder},
                        Case{"what is above the couch", RelationKind::kAbove},
                        Case{"what is below the shelf", RelationKind::kBelow},
                        Case{"what is next to the sofa", RelationKind::kNextTo},
                        Case{"what is beside the sofa", RelationKind::kNextTo},
                        Case{"what is close to the sofa", RelationKind::kNear},
                        Case{"what is inside the shelf", RelationKind::kInside},
                        Case{"what is on top of the shelf", RelationKind::kOn}}) {
    const ParsedQuery q = Parse(c.text);
    ASSERT_TRUE(q.relation) << c.text;
    EXPECT_EQ(q.relation->kind, c.kind) << c.text;
  }
}

TEST_F(ParserTest, Between) {
  const ParsedQuery q = Parse("what is between the chair and the couch");
  EXPECT_EQ(q.relation->kind, RelationKind::kBetween);
  EXPECT_EQ(q.relation->anchor->classes, Classes{"chair"});
  EXPECT_EQ(q.relation->anchor2->classes, Classes{"couch"});
  EXPECT_FALSE(ParseQuestion("what is between the chair", vocab_).ok());
}

TEST_F(ParserTest, Nearest) {
  const ParsedQuery a = Parse("where is the nearest chair to the table");
  EXPECT_EQ(a.intent, Intent::kNearest);
  EXPECT_EQ(a.target->classes, Classes{"chair"});
  EXPECT_EQ(a.relation->anchor->classes, Classes{"dining table"});
  const ParsedQuery b = Parse("which chair is closest to the sofa");
  EXPECT_EQ(b.intent, Intent::kNearest);
  EXPECT_EQ(b.relation->anchor->classes, Classes{"couch"});
  const ParsedQuery c = Parse("where is the nearest cup");
  EXPECT_EQ(c.intent, Intent::kNearest);
  EXPECT_FALSE(c.relation->anchor);
}

TEST_F(ParserTest, CheckRelation) {
  const ParsedQuery q = Parse("Is the mug on the desk?");
  EXPECT_EQ(q.intent, Intent::kCheckRelation);
  EXPECT_EQ(q.target->classes, Classes{"cup"});
  EXPECT_EQ(IntentName(q), "check_on");
}

TEST_F(ParserTest, SynonymsMapToDetectorClasses) {
  const std::pair<const char*, const char*> cases[] = {{"tv", "tv"},
                                                       {"monitor", "tv"},
                                                       {"screen", "tv"},
                                                       {"display", "tv"},
                                                       {"dining table", "dining table"},
                                                       {"table", "dining table"},
                                                       {"desk", "dining table"},
                                                       {"couch", "couch"},
                                                       {"sofa", "couch"},
                                                       {"cup", "cup"},
                                                       {"mug", "cup"},
                                                       {"plant", "potted plant"},
                                                       {"phone", "cell phone"},
                                                       {"fridge", "refrigerator"},
                                                       {"teddy", "teddy bear"}};
  for (const auto& [word, cls] : cases) {
    const ParsedQuery q = Parse(std::string("where is the ") + word);
    EXPECT_EQ(q.target->classes, Classes{cls}) << word;
  }
}

TEST_F(ParserTest, Plurals) {
  const std::pair<const char*, const char*> cases[] = {{"chairs", "chair"},
                                                       {"mugs", "cup"},
                                                       {"sofas", "couch"},
                                                       {"couches", "couch"},
                                                       {"dining tables", "dining table"},
                                                       {"shelves", "shelf"},
                                                       {"people", "person"},
                                                       {"mice", "mouse"},
                                                       {"glasses", "wine glass"},
                                                       {"teddy bears", "teddy bear"},
                                                       {"benches", "bench"}};
  for (const auto& [word, cls] : cases) {
    const ParsedQuery q = Parse(std::string("how many ") + word + " are there");
    EXPECT_EQ(q.target->classes, Classes{cls}) << word;
    EXPECT_TRUE(q.target->plural) << word;
  }
}

TEST_F(ParserTest, MultiWordClassIsNotARelation) {
  // "hot dog" contains no relation; "tennis racket on the table" splits after the class.
  const ParsedQuery q = Parse("where is the hot dog on the table");
  EXPECT_EQ(q.target->classes, Classes{"hot dog"});
  EXPECT_EQ(q.relation->kind, RelationKind::kOn);
}

TEST_F(ParserTest, ObjectIds) {
  const ParsedQuery a = Parse("what is on #3");
  EXPECT_EQ(a.relation->anchor->id, 3);
  const ParsedQuery b = Parse("where is object 12");
  EXPECT_EQ(b.target->id, 12);
}

TEST_F(ParserTest, Paraphrases) {
  struct Case {
    const char* text;
    Intent intent;
  };
  for (const Case& c : {Case{"where did you see the cup", Intent::kWhere},
                        Case{"where was the laptop last seen?", Intent::kWhere},
                        Case{"show me the mugs on the desk", Intent::kWhere},
                        Case{"find the remote control", Intent::kWhere},
                        Case{"How many people are in the room?", Intent::kCount},
                        Case{"Which robot has seen the mouse?", Intent::kWhichRobot},
                        Case{"can you see a teddy bear", Intent::kExists},
                        Case{"are there any bottles on the table", Intent::kExists},
                        Case{"what objects are on top of the shelf", Intent::kWhatRelation},
                        Case{"what's there", Intent::kList}}) {
    auto q = ParseQuestion(c.text, vocab_);
    ASSERT_TRUE(q.ok()) << c.text << ": " << q.status().message();
    EXPECT_EQ(q->intent, c.intent) << c.text;
  }
}

TEST_F(ParserTest, UnknownWordsListWhatIsKnown) {
  auto q = ParseQuestion("where is the unicorn", vocab_);
  ASSERT_FALSE(q.ok());
  EXPECT_EQ(q.status().code(), absl::StatusCode::kInvalidArgument);
  const std::string msg(q.status().message());
  EXPECT_NE(msg.find("\"unicorn\""), std::string::npos) << msg;
  EXPECT_NE(msg.find("dining table"), std::string::npos) << msg;
  EXPECT_NE(msg.find("where is the X"), std::string::npos) << msg;
  EXPECT_NE(msg.find("left of"), std::string::npos) << msg;

  auto adj = ParseQuestion("where is the red cup", vocab_);
  ASSERT_FALSE(adj.ok());
  EXPECT_NE(std::string(adj.status().message()).find("\"red\""), std::string::npos);
  EXPECT_FALSE(ParseQuestion("", vocab_).ok());
  EXPECT_FALSE(ParseQuestion("?!", vocab_).ok());
  EXPECT_FALSE(ParseQuestion("where is", vocab_).ok());
  EXPECT_FALSE(ParseQuestion("what is on the", vocab_).ok());
  EXPECT_FALSE(ParseQuestion("how many", vocab_).ok());
}

TEST_F(ParserTest, ClassesFromTheMapAreLearned) {
  Vocabulary v(QueryOptions::Defaults());
  EXPECT_FALSE(ParseQuestion("where is the whiteboard", v).ok());
  v.AddClass("whiteboard");
  auto q = ParseQuestion("how many whiteboards are there", v);
  ASSERT_TRUE(q.ok());
  EXPECT_EQ(q->target->classes, Classes{"whiteboard"});
}

TEST(TokenizeTest, ContractionsAndPunctuation) {
  EXPECT_EQ(Tokenize("What's on the Table?"),
            (std::vector<std::string>{"what", "is", "on", "the", "table"}));
  EXPECT_EQ(Tokenize("Where\xE2\x80\x99s robot-a's #12, please!"),
            (std::vector<std::string>{"where", "is", "robot-a", "is", "#12", "please"}));
}

}  // namespace
}  // namespace loci::query
