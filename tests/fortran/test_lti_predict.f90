!> The linear time-invariant fast path of the output-error predictor
!> (mlid_lti_predict, taken by oe_predict for a linear_model_t) against the
!> RK4 path it replaces and against central differences.  The RK4 path is
!> reached with an extension of linear_model_t that changes nothing: the
!> fast path takes the linear model's own type only.  Outputs and
!> sensitivities must agree with the RK4 path to rounding (relative 1e-11
!> of each column's largest value: the two evaluate the same polynomial map
!> in another order) and with differences to their truncation (1e-6).
program test_lti_predict
  use mlid_kinds, only: wp, MLID_OK
  use mlid_models, only: model_t, linear_model_t, model_layout, layout_t
  use mlid_model_factory, only: model_create, MODEL_LINEAR
  use mlid_params, only: param_map_t, param_map_create, no_ties, apply_ties, tie_t
  use mlid_options, only: options_t
  use mlid_filter, only: oe_predict
  use mlid_lti_predict, only: lti_exact
  use test_checks, only: check, finish
  implicit none

  !> The linear model by the RK4 path (an extension: not the fast path's type).
  type, extends(linear_model_t) :: rk_linear_t
  end type rk_linear_t

  call short_period_held(101)
  call short_period_held(1300)        ! a long record: the sensitivities carried over many samples
  call feedback_ties_segments()
  call three_states_five_outputs()
  call other_sizes(5)                 ! a whole group of four states and one left
  call other_sizes(1)
  call other_sizes(6)                 ! advance_wide: a group and two left
  call other_sizes(7)
  call finish()

contains

  !> C-8's four states (cases/c8_monte_carlo): F and G entries, an initial
  !> state and a bias free; input held over each sample (zoh), one RK4 step;
  !> nt samples.
  subroutine short_period_held(nt)
    integer, intent(in) :: nt
    integer, parameter :: nx = 4, nu = 1, ny = 4
    character(len=16) :: n
    type(linear_model_t) :: lin
    type(options_t) :: opt
    real(wp), allocatable :: theta(:), t(:), u(:, :)
    integer, allocatable :: isfree(:)
    type(layout_t) :: l
    integer :: j

    call linear(nx, nu, ny, lin)
    l = model_layout(lin)
    allocate (theta(l%nth), isfree(l%nth))
    theta = 0.0_wp
    isfree = 0
    theta(lin%of + 1:lin%of + 16) = [-0.02_wp, 0.0_wp, 0.003_wp, -0.004_wp, -32.2_wp, 0.0_wp, &
                                     0.0_wp, 0.0_wp, 0.0_wp, 1.0_wp, -2.382_wp, 1.0_wp, &
                                     33.74_wp, 0.0_wp, -0.281_wp, -0.3685_wp]
    theta(lin%og + 1:lin%og + 4) = [0.0_wp, 0.0_wp, -0.829_wp, 0.0025_wp]
    theta(lin%oh + [1, 6, 11, 16]) = 1.0_wp
    isfree(lin%of + [11, 15, 16]) = 1
    isfree(lin%og + [3, 4]) = 1
    theta(l%ox0 + 3) = 0.01_wp
    isfree(l%ox0 + 3) = 1
    isfree(l%obias + 2) = 1
    allocate (t(nt), u(nu, nt))
    t = [(0.02_wp*(j - 1), j=1, nt)]
    u(1, :) = [(10.0_wp*sin(0.3_wp*j) + merge(5.0_wp, -5.0_wp, mod(j, 200) < 40), j=1, nt)]
    opt%hold = .true.
    write (n, '(i0)') nt
    call compare('C-8 short period, held input, '//trim(n)//' samples', lin, theta, isfree, no_ties(l%nth), [1], t, u, opt)
  end subroutine short_period_held

  !> Two states, two inputs, three outputs, with every part the fast path
  !> reads: state feedback K (one entry free), D and bx free, H(1,1) tied to
  !> F(1,1) with scale 2, the input linear between samples over three RK4
  !> steps, and two manoeuvres (each its own x0 and biases).
  subroutine feedback_ties_segments()
    integer, parameter :: nx = 2, nu = 2, ny = 3, nt = 300
    type(linear_model_t) :: lin
    type(options_t) :: opt
    type(tie_t) :: tie
    real(wp), allocatable :: theta(:), t(:), u(:, :)
    integer, allocatable :: isfree(:)
    type(layout_t) :: l
    integer :: j

    call linear(nx, nu, ny, lin)
    l = model_layout(lin, [1, 141])
    allocate (theta(l%nth), isfree(l%nth))
    theta = 0.0_wp
    isfree = 0
    theta(lin%of + 1:lin%of + 4) = [-1.2_wp, 0.6_wp, -2.5_wp, -0.9_wp]
    theta(lin%og + 1:lin%og + 4) = [1.5_wp, -0.3_wp, 0.2_wp, 0.8_wp]
    theta(lin%oh + 1:lin%oh + 6) = [-2.4_wp, 1.0_wp, 0.0_wp, 0.0_wp, 0.0_wp, 1.0_wp]
    theta(lin%od + 1:lin%od + 6) = [0.4_wp, 0.0_wp, 0.1_wp, 0.0_wp, 0.0_wp, -0.2_wp]
    theta(lin%ok + 1:lin%ok + 4) = [0.05_wp, 0.0_wp, -0.1_wp, 0.02_wp]     ! K (nu x nx)
    theta(lin%obx + 1:lin%obx + 2) = [0.01_wp, -0.02_wp]
    isfree(lin%of + [1, 2, 3, 4]) = 1
    isfree(lin%og + [1, 4]) = 1
    isfree(lin%od + [1, 6]) = 1
    isfree(lin%ok + 3) = 1
    isfree(lin%obx + [1, 2]) = 1
    tie = no_ties(l%nth)
    tie%to = [lin%oh + 1]
    tie%from = [lin%of + 1]
    tie%scale = [2.0_wp]
    call apply_ties(tie, theta)
    theta(l%ox0 + 1:l%ox0 + 4) = [0.1_wp, -0.05_wp, 0.0_wp, 0.2_wp]
    isfree(l%ox0 + [1, 4]) = 1
    isfree(l%obias + [2, 6]) = 1
    allocate (t(nt), u(nu, nt))
    t = [(0.05_wp*(j - 1), j=1, 140), (0.05_wp*(j - 141) + 30.0_wp, j=141, nt)]
    u(1, :) = [(sin(0.21_wp*j) + merge(1.0_wp, 0.0_wp, mod(j, 50) < 10), j=1, nt)]
    u(2, :) = [(0.5_wp*cos(0.13_wp*j), j=1, nt)]
    opt%substeps = 3
    call compare('feedback, ties, two manoeuvres, linear input, 3 substeps', lin, theta, isfree, &
                 tie, [1, 141], t, u, opt)
  end subroutine feedback_ties_segments

  !> A lateral-directional model with three states (beta, p, r): a state
  !> count without the fast path's fixed-size kernels, five outputs (a
  !> strip of four rows and one left over), seven columns with states'
  !> sensitivities (not a whole number of strips: padding rows), one free H
  !> and one free D entry that do not move the states, an initial state and
  !> a bias free; input linear between samples over two RK4 steps.
  subroutine three_states_five_outputs()
    integer, parameter :: nx = 3, nu = 2, ny = 5, nt = 400
    type(linear_model_t) :: lin
    type(options_t) :: opt
    real(wp), allocatable :: theta(:), t(:), u(:, :)
    integer, allocatable :: isfree(:)
    type(layout_t) :: l
    integer :: j

    call linear(nx, nu, ny, lin)
    l = model_layout(lin)
    allocate (theta(l%nth), isfree(l%nth))
    theta = 0.0_wp
    isfree = 0
    theta(lin%of + 1:lin%of + 9) = [-0.15_wp, -4.0_wp, 2.0_wp, 0.05_wp, -1.5_wp, -0.05_wp, &
                                    -0.98_wp, 0.6_wp, -0.25_wp]
    theta(lin%og + 1:lin%og + 6) = [0.0_wp, -3.0_wp, 0.1_wp, 0.03_wp, 0.5_wp, -1.2_wp]
    theta(lin%oh + 1:lin%oh + 15) = [1.0_wp, 0.0_wp, 0.0_wp, -2.0_wp, 0.5_wp, &
                                     0.0_wp, 1.0_wp, 0.0_wp, 0.1_wp, 0.0_wp, &
                                     0.0_wp, 0.0_wp, 1.0_wp, 0.3_wp, -0.2_wp]
    theta(lin%od + [4, 9]) = [0.05_wp, 0.2_wp]
    isfree(lin%of + [2, 5, 7, 9]) = 1
    isfree(lin%og + [2, 6]) = 1
    isfree(lin%oh + 4) = 1
    isfree(lin%od + 9) = 1
    theta(l%ox0 + 1:l%ox0 + 3) = [0.02_wp, 0.0_wp, -0.01_wp]
    isfree(l%ox0 + 2) = 1
    isfree(l%obias + 4) = 1
    allocate (t(nt), u(nu, nt))
    t = [(0.04_wp*(j - 1), j=1, nt)]
    u(1, :) = [(0.1_wp*sin(0.17_wp*j) + merge(0.05_wp, 0.0_wp, mod(j, 120) < 15), j=1, nt)]
    u(2, :) = [(0.05_wp*cos(0.11_wp*j), j=1, nt)]
    opt%substeps = 2
    call compare('three states, five outputs, linear input, 2 substeps', lin, theta, isfree, &
                 no_ties(l%nth), [1], t, u, opt)
  end subroutine three_states_five_outputs

  !> nx states in a chain (state i driven by i-1 and the input), two
  !> outputs, the input held over each sample, one RK4 step: the state
  !> counts the fast path takes in groups of four (five: one group and one
  !> state left) or alone (one); free: the diagonal of F, G(1), x0(nx),
  !> one H entry and no bias (no column with only a bias term).
  subroutine other_sizes(nx)
    integer, intent(in) :: nx
    integer, parameter :: nu = 1, ny = 2, nt = 250
    character(len=16) :: n
    type(linear_model_t) :: lin
    type(options_t) :: opt
    real(wp), allocatable :: theta(:), t(:), u(:, :)
    integer, allocatable :: isfree(:)
    type(layout_t) :: l
    integer :: i, j

    call linear(nx, nu, ny, lin)
    l = model_layout(lin)
    allocate (theta(l%nth), isfree(l%nth))
    theta = 0.0_wp
    isfree = 0
    do i = 1, nx
      theta(lin%of + (i - 1)*nx + i) = -0.8_wp - 0.3_wp*i      ! F(i, i)
      isfree(lin%of + (i - 1)*nx + i) = 1
      if (i > 1) theta(lin%of + (i - 2)*nx + i) = 0.5_wp       ! F(i, i-1)
    end do
    theta(lin%og + 1:lin%og + nx) = [(1.0_wp/i, i=1, nx)]
    isfree(lin%og + 1) = 1
    theta(lin%oh + 1) = 1.0_wp                                   ! H(1, 1)
    theta(lin%oh + 2*nx) = 1.0_wp                                ! H(2, nx)
    isfree(lin%oh + 2*nx) = 1
    theta(l%ox0 + nx) = 0.05_wp
    isfree(l%ox0 + nx) = 1
    allocate (t(nt), u(nu, nt))
    t = [(0.05_wp*(j - 1), j=1, nt)]
    u(1, :) = [(sin(0.15_wp*j) + merge(0.5_wp, 0.0_wp, mod(j, 60) < 8), j=1, nt)]
    opt%hold = .true.
    write (n, '(i0)') nx
    call compare(trim(n)//' states in a chain, held input, no free bias', lin, theta, isfree, &
                 no_ties(l%nth), [1], t, u, opt)
  end subroutine other_sizes

  subroutine linear(nx, nu, ny, lin)
    integer, intent(in) :: nx, nu, ny
    type(linear_model_t), intent(out) :: lin
    class(model_t), allocatable :: m
    integer :: status
    character(len=256) :: msg
    call model_create(MODEL_LINEAR, nx, nu, ny, 0, [integer ::], [real(wp) ::], m, status, msg)
    call check(status == MLID_OK, 'linear model: '//trim(msg))
    select type (m)
    type is (linear_model_t)
      lin = m
    end select
  end subroutine linear

  !> The fast path's yhat and dy against the RK4 path's and against central
  !> differences of the fast path's yhat.
  subroutine compare(what, lin, theta, isfree, tie, seg, t, u, opt)
    character(len=*), intent(in) :: what
    type(linear_model_t), intent(in) :: lin
    real(wp), intent(in) :: theta(:), t(:), u(:, :)
    integer, intent(in) :: isfree(:), seg(:)
    type(tie_t), intent(in) :: tie
    type(options_t), intent(in) :: opt
    type(rk_linear_t) :: rk
    type(param_map_t) :: pm
    real(wp), allocatable :: yf(:, :), yr(:, :), dyf(:, :, :), dyr(:, :, :), xf(:, :), xr(:, :), &
                             yp(:, :), ym(:, :), th(:), fd(:, :, :)
    real(wp) :: h, rel_rk, rel_fd, rel_y
    integer :: status, k, nf, ny, nt, ends(size(seg))
    character(len=256) :: msg

    rk%linear_model_t = lin
    call param_map_create(model_layout(lin, seg), isfree, tie, pm, status, msg)
    call check(status == MLID_OK, what//': parameter map '//trim(msg))
    ends = [seg(2:) - 1, size(t)]
    call check(all([(lti_exact(lin, theta, pm, t, seg(k), ends(k)), k=1, size(seg))]) .and. &
               .not. lti_exact(rk, theta, pm, t, 1, ends(1)), what//': paths chosen')
    if (size(seg) > 1) call check(.not. lti_exact(lin, theta, pm, t, 1, size(t)), &
                                  what//': uneven samples refused')
    nf = pm%nf
    ny = lin%ny
    nt = size(t)
    allocate (yf(ny, nt), yr(ny, nt), dyf(ny, nf, nt), dyr(ny, nf, nt), xf(lin%nx, nt), &
              xr(lin%nx, nt), yp(ny, nt), ym(ny, nt), fd(ny, nf, nt))
    call oe_predict(lin, theta, pm, t, u, opt, yf, status, msg, dy=dyf, xhist=xf)
    call check(status == MLID_OK, what//': fast path '//trim(msg))
    call oe_predict(rk, theta, pm, t, u, opt, yr, status, msg, dy=dyr, xhist=xr)
    call check(status == MLID_OK, what//': RK4 path '//trim(msg))
    rel_y = max(maxval(abs(yf - yr))/maxval(abs(yr)), maxval(abs(xf - xr))/maxval(abs(xr)))
    rel_rk = 0.0_wp
    do k = 1, nf
      rel_rk = max(rel_rk, maxval(abs(dyf(:, k, :) - dyr(:, k, :)))/maxval(abs(dyr(:, k, :))))
    end do
    call oe_predict(lin, theta, pm, t, u, opt, yp, status, msg)
    call check(maxval(abs(yp - yf)) == 0.0_wp, what//': outputs the same without sensitivities')
    do k = 1, nf                     ! central differences, ties followed
      h = 1.0e-6_wp*max(1.0_wp, abs(theta(pm%ifree(k))))
      th = theta
      th(pm%ifree(k)) = th(pm%ifree(k)) + h
      call apply_ties(tie, th)
      call oe_predict(lin, th, pm, t, u, opt, yp, status, msg)
      th = theta
      th(pm%ifree(k)) = th(pm%ifree(k)) - h
      call apply_ties(tie, th)
      call oe_predict(lin, th, pm, t, u, opt, ym, status, msg)
      fd(:, k, :) = (yp - ym)/(2*h)
    end do
    rel_fd = 0.0_wp
    do k = 1, nf
      rel_fd = max(rel_fd, maxval(abs(dyf(:, k, :) - fd(:, k, :)))/maxval(abs(fd(:, k, :))))
    end do
    write (*, '(a,3(a,es9.2))') what, ': max relative difference to RK4, states and outputs ', &
      rel_y, ', sensitivities ', rel_rk, '; to central differences ', rel_fd
    call check(rel_y < 1.0e-12_wp, what//': states and outputs equal the RK4 path''s to rounding')
    call check(rel_rk < 1.0e-11_wp, what//': sensitivities equal the RK4 path''s to rounding')
    call check(rel_fd < 1.0e-6_wp, what//': sensitivities agree with central differences')
  end subroutine compare

end program test_lti_predict
