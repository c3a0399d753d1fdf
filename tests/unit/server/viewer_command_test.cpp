// Viewer controls: every accepted shape, and refusals naming the field for anything doubtful.
#include "server/viewer/viewer_command.h"

#include <gtest/gtest.h>

namespace rtpm::server {
namespace {

const ScriptEdit& edit(const ViewerParse& p) { return std::get<ViewerEdit>(p.command()).edit; }

TEST(ViewerCommand, AcceptsEveryControl) {
    ViewerParse cam = parseViewerCommand(R"({"type":"camera","eye":[1,2,3],"target":[0,0,0]})");
    ASSERT_TRUE(cam.ok()) << cam.error();
    EXPECT_EQ(edit(cam).kind, ScriptEdit::Kind::Camera);
    EXPECT_EQ(*edit(cam).camera.eye, Vec3(1, 2, 3));
    ViewerParse light = parseViewerCommand(R"({"type":"light","index":0,"position":[0.5,1,-2]})");
    ASSERT_TRUE(light.ok()) << light.error();
    EXPECT_EQ(edit(light).kind, ScriptEdit::Kind::Light);
    ViewerParse mat = parseViewerCommand(R"({"type":"material","index":1,"ior":1.5,"color":[1,0.5,0]})");
    ASSERT_TRUE(mat.ok()) << mat.error();
    EXPECT_EQ(*edit(mat).material.ior, 1.5f);
    ViewerParse tr = parseViewerCommand(R"({"type":"transform","index":2,"translate":[0.1,0,0]})");
    ASSERT_TRUE(tr.ok()) << tr.error();
    ViewerParse set = parseViewerCommand(R"({"type":"settings","M":4,"k":32,"tree":"grid"})");
    ASSERT_TRUE(set.ok()) << set.error();
    EXPECT_EQ(*edit(set).knob(Knob::Interleave), 4);
    EXPECT_EQ(*edit(set).knob(Knob::Tree), double(PhotonTree::UniformGrid));
    EXPECT_FALSE(edit(set).knob(Knob::Estimator));
    ViewerParse est = parseViewerCommand(R"({"type":"settings","estimator":"knn"})");
    ASSERT_TRUE(est.ok()) << est.error();
    EXPECT_EQ(*edit(est).knob(Knob::Estimator), double(CausticEstimatorKind::Knn));
    // The knob table's limits: k up to 4096 (was 1024 here), P up to 5e7 (was 1e7), r_max a number.
    ViewerParse big = parseViewerCommand(R"({"type":"settings","k":4096,"P":50000000,"rmax":0.5})");
    ASSERT_TRUE(big.ok()) << big.error();
    EXPECT_EQ(*edit(big).knob(Knob::K), 4096);
    EXPECT_EQ(*edit(big).knob(Knob::RMax), 0.5);
    ViewerParse gamma = parseViewerCommand(R"({"type":"settings","confidence":0.75})");
    ASSERT_TRUE(gamma.ok()) << gamma.error();
    EXPECT_EQ(*edit(gamma).knob(Knob::Confidence), 0.75);
    ViewerParse glossy = parseViewerCommand(R"({"type":"settings","glossy":12})");
    ASSERT_TRUE(glossy.ok()) << glossy.error();
    EXPECT_EQ(*edit(glossy).knob(Knob::GlossySamples), 12);
    ViewerParse d = parseViewerCommand(R"({"type":"display","layer":"caustic_unfiltered","exposure":-1.5})");
    ASSERT_TRUE(d.ok()) << d.error();
    EXPECT_EQ(std::get<ViewerDisplay>(d.command()).layer, ViewerLayer::CausticUnfiltered);
    EXPECT_TRUE(parseViewerCommand(R"({"type":"pause","paused":true})").ok());
    EXPECT_TRUE(parseViewerCommand(R"({"type":"snapshot"})").ok());
    EXPECT_TRUE(parseViewerCommand(R"({"type":"script"})").ok());
    EXPECT_TRUE(parseViewerCommand(R"({"type":"ack","frame":12})").ok());
    EXPECT_EQ(std::get<ViewerHello>(parseViewerCommand(R"({"type":"hello","token":"abc"})").command()).token, "abc");
}

TEST(ViewerCommand, RefusesMalformedControlsNamingWhatIsWrong) {
    auto refused = [](const std::string& text, const std::string& mention) {
        ViewerParse p = parseViewerCommand(text);
        ASSERT_FALSE(p.ok()) << text;
        EXPECT_NE(p.error().find(mention), std::string::npos) << text << " → " << p.error();
    };
    refused("not json", "not valid JSON");
    refused("[1,2]", "JSON object");
    refused(R"({"eye":[1,2,3]})", "type");
    refused(R"({"type":"teleport"})", "unknown control type");
    refused(R"({"type":"camera","eye":[1,"x",3]})", "eye");
    refused(R"({"type":"camera","eye":[1,2]})", "3 numbers");
    refused(R"({"type":"camera","yfov":1e999})", "not valid JSON");  // nlohmann refuses overflow
    refused(R"({"type":"camera","eye":[1e300,0,0]})", "eye");
    refused(R"({"type":"camera","yfov":4})", "yfov");
    refused(R"({"type":"camera"})", "needs eye");
    refused(R"({"type":"camera","eye":[0,0,0],"fov":1})", "unknown field \"fov\"");
    refused(R"({"type":"light","position":[0,0,0]})", "index");
    refused(R"({"type":"light","index":-1,"position":[0,0,0]})", "index");
    refused(R"({"type":"light","index":0.5,"position":[0,0,0]})", "integer");
    refused(R"({"type":"light","index":0,"intensity":[-1,0,0]})", "intensity");
    refused(R"({"type":"material","index":0,"color":[2,0,0]})", "color");
    refused(R"({"type":"material","index":0,"ior":0.5})", "ior");
    refused(R"({"type":"settings","M":0})", "\"M\"");
    refused(R"({"type":"settings","P":100000000})", "\"P\"");
    refused(R"({"type":"settings","k":4097})", "\"k\"");
    refused(R"({"type":"settings","confidence":0})", "\"confidence\"");
    refused(R"({"type":"settings","glossy":65})", "\"glossy\"");
    refused(R"({"type":"settings","tree":"oak"})", "middle|median|grid");
    refused(R"({"type":"settings","Q":1})", "unknown field \"Q\"");
    refused(R"({"type":"settings"})", "needs one of its keys");
    refused(R"({"type":"settings","tree":"oak"})", "tree");
    refused(R"({"type":"settings","estimator":"sppm"})", "estimator");
    refused(R"({"type":"settings","estimator":1})", "estimator");
    refused(R"({"type":"display","layer":"depth","exposure":0})", "layer");
    refused(R"({"type":"display","layer":"final","exposure":99})", "exposure");
    refused(R"({"type":"pause","paused":"yes"})", "paused");
    refused(R"({"type":"hello","token":5})", "token");
    refused(std::string(kMaxViewerMessageBytes + 1, ' '), "limit");
}

}  // namespace
}  // namespace rtpm::server
